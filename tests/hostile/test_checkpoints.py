"""Checkpoints are files people download and share: loading one runs no code, and one that is not svhdesc's, not of
the task, or holds weights that are not finite is one ``error:`` line naming the file, exit 2, nothing written, in
``train --resume`` and in ``play --checkpoint``.

Seeded faults, each failing the test named: ``load_checkpoint`` loading with ``weights_only=False`` (the crafted
pickle writes its marker: test_a_crafted_pickle_runs_no_code); ``load_checkpoint`` not looking for non-finite
numbers (the NaN checkpoint is taken: test_non_finite_weights_are_refused); ``restore`` not comparing the widths
its infos state with the environment's (the checkpoint is taken: test_a_checkpoint_of_other_widths_is_refused)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest

torch = pytest.importorskip("torch")
pytest.importorskip("rsl_rl")

from svhdesc.learn import task  # noqa: E402
from svhdesc.learn.checkpoint import policy_info  # noqa: E402
from svhdesc.learn.env import TaskEnv  # noqa: E402
from svhdesc.learn.train import make_runner, ppo_config  # noqa: E402
from tests.support import fails_cleanly  # noqa: E402

TRAIN = ("--backend", "mujoco", "--iterations", "1")


class Payload:
    """Unpickled without ``weights_only``, this object is ``open(marker, "w")``: the file appears."""

    def __init__(self, marker: Path) -> None:
        self.marker = marker

    def __reduce__(self) -> tuple[Any, ...]:
        return (open, (str(self.marker), "w"))


@pytest.fixture(scope="module")
def reach_checkpoint(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Any]:
    """An untrained svh_reach checkpoint as ``train`` saves it (rsl-rl's dict with svhdesc's infos), in memory."""
    reach = task("svh_reach")
    env = TaskEnv(reach, 1, backend="mujoco")
    runner = make_runner(env, ppo_config(reach.training), None)
    path = tmp_path_factory.mktemp("reach") / "model_0.pt"
    runner.save(str(path), infos=policy_info(reach, env))
    return torch.load(str(path), weights_only=True)


def _refused_everywhere(folder: Path, checkpoint: Path, match: str) -> list[str]:
    """``train --resume`` (whose run folder is the checkpoint's) and ``play`` refuse it by name, leaving the folder
    as it was; their error lines."""
    lines = [
        fails_cleanly(folder, "train", "svh_reach", "--resume", str(checkpoint), *TRAIN, match=match),
        fails_cleanly(folder, "play", "svh_reach", "--checkpoint", str(checkpoint), match=match),
    ]
    assert all(line.startswith(f"error: {checkpoint}: ") for line in lines), lines
    return lines


def test_a_crafted_pickle_runs_no_code(tmp_path: Path) -> None:
    folder = tmp_path / "run"
    folder.mkdir()
    marker = tmp_path / "ran.txt"
    checkpoint = folder / "model_5.pt"
    torch.save({"infos": {"task": "svh_reach"}, "iter": 5, "payload": Payload(marker)}, checkpoint)
    for line in _refused_everywhere(folder, checkpoint, "refused: it holds more than weights and plain data"):
        assert "io.open" in line, line  # what it would have called, named
    assert not marker.exists()


def test_files_that_are_not_svhdesc_checkpoints(tmp_path: Path) -> None:
    folder = tmp_path / "run"
    folder.mkdir()
    plain = folder / "plain.pt"
    torch.save({"model": torch.zeros(3)}, plain)
    _refused_everywhere(folder, plain, "not an svhdesc checkpoint (no task in it)")
    text = folder / "notes.pt"
    text.write_text("not a checkpoint at all\n")
    _refused_everywhere(folder, text, "not a checkpoint")
    weightless = folder / "model_1.pt"
    torch.save({"iter": 1, "infos": {"task": "svh_reach"}}, weightless)
    _refused_everywhere(folder, weightless, "no actor_state_dict in it")
    for steps in (-5, "many", 2.5):  # a resumed run's count goes on from it
        torch.save({"iter": 1, "infos": {"task": "svh_reach", "env_steps": steps}}, weightless)
        _refused_everywhere(folder, weightless, f"env_steps {steps!r} in it is not a count")


def test_non_finite_weights_are_refused(tmp_path: Path, reach_checkpoint: dict[str, Any]) -> None:
    folder = tmp_path / "run"
    folder.mkdir()
    broken = {**reach_checkpoint, "actor_state_dict": dict(reach_checkpoint["actor_state_dict"])}
    name = next(key for key in broken["actor_state_dict"] if key.endswith("weight"))
    weight = broken["actor_state_dict"][name].clone()
    weight[0, 0] = float("nan")
    broken["actor_state_dict"][name] = weight
    checkpoint = folder / "model_9.pt"
    torch.save(broken, checkpoint)
    _refused_everywhere(folder, checkpoint, f"actor_state_dict.{name} holds a number that is not finite")
    infinite = {**reach_checkpoint, "critic_state_dict": dict(reach_checkpoint["critic_state_dict"])}
    name = next(iter(infinite["critic_state_dict"]))
    infinite["critic_state_dict"][name] = torch.full_like(infinite["critic_state_dict"][name], float("inf"))
    torch.save(infinite, checkpoint)
    _refused_everywhere(folder, checkpoint, "critic_state_dict.")


def test_a_checkpoint_of_other_widths_is_refused(tmp_path: Path, reach_checkpoint: dict[str, Any]) -> None:
    """A checkpoint naming the task but trained on other observations (an older task definition) is refused by
    name, before rsl-rl's size-mismatch traceback."""
    folder = tmp_path / "run"
    folder.mkdir()
    checkpoint = folder / "model_2.pt"
    torch.save({**reach_checkpoint, "infos": {**reach_checkpoint["infos"], "actor_obs": 7}}, checkpoint)
    _refused_everywhere(folder, checkpoint, "actor_obs 7 in it, the task's environment has 24")
    renamed = {**reach_checkpoint, "actor_state_dict": {"layer.weight": torch.zeros(2, 2)}}
    torch.save(renamed, checkpoint)
    _refused_everywhere(folder, checkpoint, "its networks do not fit task 'svh_reach'")


def test_a_good_checkpoint_still_loads(tmp_path: Path, reach_checkpoint: dict[str, Any]) -> None:
    """The checks refuse only what is wrong: the untrained checkpoint plays an episode."""
    from tests.support import run_cli

    checkpoint = tmp_path / "model_0.pt"
    torch.save(reach_checkpoint, checkpoint)
    result = run_cli("play", "svh_reach", "--checkpoint", str(checkpoint), "--episodes", "1", in_process=True)
    assert result.returncode == 0 and "error" not in result.stderr, result.stderr
