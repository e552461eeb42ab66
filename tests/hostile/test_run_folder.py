"""A train run folder holds svhdesc's own state only: no git status or diff of any repository (rsl-rl's code-state
store is switched off), files with the user's umask, and a resumed run's env-steps count going on.

Seeded faults, each failing the test named: ``make_runner`` leaving rsl-rl's ``_store_code_state`` in place (it
writes ``git/<repo>.diff`` of a repository it finds: test_no_code_state_is_stored, and test_a_run_and_its_resume
where the installed rsl_rl lies in a git checkout, as in this one's .venv); ``replaced`` without its ``fchmod``
(checkpoint and policy 0600: test_a_run_and_its_resume); ``Session.start`` not taking ``env_steps`` from the
checkpoint (the resumed count restarts at 32: the same test).
"""

from __future__ import annotations

import os
import stat
from collections.abc import Iterator
from pathlib import Path

import pytest

torch = pytest.importorskip("torch")
pytest.importorskip("rsl_rl")

from svhdesc.learn import task  # noqa: E402
from svhdesc.learn.env import TaskEnv  # noqa: E402
from svhdesc.learn.train import make_runner, ppo_config  # noqa: E402
from tests.support import REPO, run_cli  # noqa: E402

MASK = 0o027  # group may read, others nothing: 0640 for a file


@pytest.fixture
def umask() -> Iterator[int]:
    before = os.umask(MASK)
    try:
        yield MASK
    finally:
        os.umask(before)


def test_no_code_state_is_stored(tmp_path: Path) -> None:
    """Even given a repository to diff (svhdesc's own checkout), the logger writes no git folder and no diff."""
    reach = task("svh_reach")
    runner = make_runner(TaskEnv(reach, 1, backend="mujoco"), ppo_config(reach.training), tmp_path)
    runner.logger.git_status_repos.append(str(REPO / "svhdesc" / "__init__.py"))
    runner.logger.init_logging_writer()
    runner.logger.writer.close()
    names = [p.relative_to(tmp_path).as_posix() for p in tmp_path.rglob("*")]
    assert names and all(name.startswith("events.out.tfevents.") for name in names), names


def test_a_run_and_its_resume(tmp_path: Path, umask: int) -> None:
    out = tmp_path / "run"
    common = ("--envs", "2", "--backend", "mujoco", "--iterations", "1")
    first = run_cli("train", "svh_reach", *common, "--out", str(out), in_process=True)
    assert first.returncode == 0, first.stderr
    second = run_cli("train", "svh_reach", *common, "--resume", str(out / "model_0.pt"), in_process=True)
    assert second.returncode == 0, second.stderr
    batch = 2 * task("svh_reach").training.steps_per_env  # env-steps an iteration of 2 worlds
    assert f"it 1  env-steps {2 * batch:,}  " in second.stderr + second.stdout, second.stdout
    saved = torch.load(str(out / "model_1.pt"), weights_only=True)
    assert saved["infos"]["env_steps"] == 2 * batch and saved["iter"] == 1
    files = sorted(p.relative_to(out).as_posix() for p in out.rglob("*"))
    assert not [name for name in files if "git" in name or name.endswith(".diff")], files
    for name in ("model_0.pt", "model_1.pt", "policy.onnx"):
        mode = stat.S_IMODE((out / name).stat().st_mode)
        assert mode == 0o666 & ~umask, (name, oct(mode))
