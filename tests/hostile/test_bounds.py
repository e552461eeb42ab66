"""Every number a user gives ``train``, ``play``, ``deploy`` and ``compare`` is bounded: refused, as one ``error:`` line
and exit 2 with nothing written, before anything is allocated. ``--envs`` by what fits this machine's memory for
the task (the figure is in the error); durations positive and finite; ``--episodes`` at least 1 (0 only beside
``play --out``); ``--frames`` at most one per control step of an episode; seeds 64-bit.

Seeded faults, each failing the test named: ``check_envs`` not called (a billion worlds: a MemoryError traceback in
Warp's allocation, or the memory limit of the child reached in MuJoCo C's: test_a_billion_worlds_are_refused);
``positive_seconds`` letting ``inf`` through (train runs, deploy starts its node: test_durations_are_finite);
``_play_counts`` or ``check_seed`` not called (test_play_counts_and_seeds); ``_ppo_bytes`` or ``_engine_bytes``
returning 0 (the estimate 0.68 or less of the growth measured: test_the_estimate_is_what_a_run_takes).
"""

from __future__ import annotations

import os
import resource
import subprocess
import sys
from pathlib import Path

import pytest

pytest.importorskip("torch")
pytest.importorskip("rsl_rl")

from tests.support import REPO, fails_cleanly  # noqa: E402

LIMIT = 12 * 2**30  # address space of a child that would allocate without a bound: a MemoryError, not the machine's


def _limited() -> None:
    resource.setrlimit(resource.RLIMIT_AS, (LIMIT, LIMIT))


def _svhdesc(*args: str, timeout: float = 120) -> subprocess.CompletedProcess[str]:
    """``svhdesc ARGS`` in a child whose memory is capped: a missing bound fails the test instead of the machine."""
    return subprocess.run(
        [sys.executable, "-m", "svhdesc.cli", *args],
        cwd=REPO,
        capture_output=True,
        text=True,
        timeout=timeout,
        preexec_fn=_limited,
        env={**os.environ, "OMP_NUM_THREADS": "1"},
    )


@pytest.mark.parametrize("backend", ["mujoco", pytest.param("warp", marks=pytest.mark.slow)])  # warp: 5-9 s
def test_a_billion_worlds_are_refused(tmp_path: Path, backend: str) -> None:
    if backend == "warp":
        pytest.importorskip("mujoco_warp")
    out = tmp_path / "run"
    result = _svhdesc("train", "svh_reach", "--envs", "1000000000", "--backend", backend, "--iterations", "1",
                      "--out", str(out))  # fmt: skip
    errors = [line for line in result.stderr.splitlines() if line.startswith("error:")]
    assert result.returncode == 2 and len(errors) == 1 and "Traceback" not in result.stderr, result.stderr
    line = errors[0]
    assert line.startswith("error: --envs 1000000000: svh_reach on ") and " a world (engine " in line, line
    assert "available on this machine hold at most " in line, line
    most = int(line.split("hold at most ")[1].split()[0])
    assert 64 <= most < 1_000_000_000, line  # the CPU default fits; a billion does not
    assert not out.exists()


def test_durations_are_finite(tmp_path: Path) -> None:
    out = tmp_path / "run"
    train = ("train", "svh_reach", "--envs", "2", "--backend", "mujoco", "--out", str(out))
    for value in ("inf", "nan", "0", "-1"):  # with an iteration count: a fault trains one iteration, not forever
        fails_cleanly(None, *train, "--iterations", "1", "--minutes", value, match="--minutes must be a positive")
    fails_cleanly(None, *train, "--iterations", "0", match="--iterations must be at least 1")
    policy = tmp_path / "policy.onnx"
    for value in ("inf", "-inf", "nan", "0"):
        args = ("deploy", "svh_rotate", "--policy", str(policy), "--duration", value)
        fails_cleanly(None, *args, match="--duration must be a positive, finite number")
        args = ("compare", "--engines", "mujoco", "--inertias", "physical", "--duration", value)
        if value in ("inf", "nan"):  # click's own range refuses the others
            fails_cleanly(None, *args, match="--duration must be a positive, finite number")
    assert not out.exists()


def test_play_counts_and_seeds(tmp_path: Path) -> None:
    from tests.learn.test_train import reach_files

    checkpoint, _ = reach_files(tmp_path)
    play = ("play", "svh_reach", "--checkpoint", checkpoint)
    picture = str(tmp_path / "strip.png")
    fails_cleanly(tmp_path, *play, "--episodes", "0", match="--episodes must be at least 1 (0 only with --out")
    fails_cleanly(tmp_path, *play, "--episodes", "-3", "--out", picture, match="--episodes must be at least 1")
    for frames in ("0", "1000000000"):
        fails_cleanly(tmp_path, *play, "--frames", frames, "--out", picture, match="--frames must be from 1 to 40")
    big = str(2**70)
    fails_cleanly(tmp_path, *play, "--seed", big, match="--seed must be a 64-bit integer")
    train = ("train", "svh_reach", "--envs", "2", "--backend", "mujoco", "--iterations", "1")
    fails_cleanly(tmp_path, *train, "--out", str(tmp_path / "run"), "--seed", big, match="--seed must be a 64-bit")
    deploy = ("deploy", "svh_reach", "--policy", str(tmp_path / "policy.onnx"), "--seed", big)
    fails_cleanly(tmp_path, *deploy, match="--seed must be a 64-bit integer")
    assert not (tmp_path / "run").exists() and not Path(picture).exists()


MEASURE = """
import json, sys, torch
from svhdesc.learn import task
from svhdesc.learn.env import TaskEnv
from svhdesc.learn.memory import world_cost
from svhdesc.learn.train import iterate, make_runner, ppo_config

def rss():
    return next(int(line.split()[1]) * 1024 for line in open("/proc/self/status") if line.startswith("VmRSS"))

reach = task("svh_reach")
torch.set_num_threads(1)
env = TaskEnv(reach, int(sys.argv[1]), backend="warp")
runner = make_runner(env, ppo_config(reach.training), None)
before = rss()
iterate(runner, env, env.get_observations())  # the kernels loaded, the storage and the update's buffers made
start = rss()
env = TaskEnv(reach, int(sys.argv[2]), backend="warp")
runner = make_runner(env, ppo_config(reach.training), None)
iterate(runner, env, env.get_observations())
print(json.dumps({"grown": rss() - start, "estimate": world_cost(reach, "warp").total}))
"""


@pytest.mark.slow
def test_the_estimate_is_what_a_run_takes() -> None:
    """The bytes a world is estimated to cost are within a quarter of what a process grows by for it: 1024 worlds
    of svh_reach on Warp's CPU and one iteration, after 16 (which load the kernels). Measured: 134.7 kB a world
    against 134.0 kB estimated; without PPO's share the estimate would be 0.68 of it."""
    pytest.importorskip("mujoco_warp")
    import json

    result = subprocess.run(
        [sys.executable, "-c", MEASURE, "16", "1040"], cwd=REPO, capture_output=True, text=True, timeout=600
    )
    assert result.returncode == 0, result.stderr[-3000:]
    figures = json.loads(result.stdout.splitlines()[-1])
    measured = figures["grown"] / 1024
    assert 0.75 < figures["estimate"] / measured < 1.33, figures
