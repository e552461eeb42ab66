"""A policy of svh_rotate driving the ROS 2 node as it would drive the real hand (``svhdesc deploy``): the simulation
(main model, the task's scene and reset state) in one process, the policy node (rclpy + onnxruntime) in another,
inside ``unshare -n`` with discovery on localhost, both in the ROS 2 venv.

The same policy, seed and number of control periods run in process on the main model (MuJoCo C through the task's
own environment) give the reference: after 2 s the hand's nine channels, as the policy node last read them from
/joint_states, are within ``BOUND`` of it (measured when written: 0.0088 rad at most). The policy is a one-iteration
one (what it does matters less than that both paths do the same with it).

Seeded faults (each failed the test, then reverted): the policy node publishing its targets in reversed joint order
(the channels 0.343 rad apart); the observer not writing the tracked cube's pose (the actor sees the cube where the
reset put it: the channels 0.139 rad apart); the forward controller left inactive (``swap_in`` skipped: the commands
are ignored, the trajectory controller holds the hand, and the test fails).
"""

from __future__ import annotations

import json
import shlex
import subprocess
import sys
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from tests.netns import private_namespace
from tests.ros2.support import PYTHON, private_env, why_not
from tests.support import REPO, run_cli

pytest.importorskip("torch")
pytest.importorskip("rsl_rl")

pytestmark = [pytest.mark.ros, pytest.mark.slow]

DURATION = 2.0  # s of simulated time the policy acts
BOUND = 0.03  # rad between the ROS 2 run's channels and the in-process run's


@pytest.fixture(scope="module")
def policy(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("rotate-policy") / "run"
    result = run_cli(
        "train", "svh_rotate", "--backend", "mujoco", "--envs", "2", "--iterations", "1", "--out", str(out), cwd=REPO
    )
    assert result.returncode == 0, result.stderr
    return out / "policy.onnx"


def in_process(policy: Path, steps: int) -> list[float]:
    import torch

    from svhdesc.learn import task
    from svhdesc.learn.deploy import nominal
    from svhdesc.learn.env import TaskEnv
    from svhdesc.learn.policy import OnnxPolicy

    rotate = task("svh_rotate")
    act = OnnxPolicy(policy, rotate)
    env = TaskEnv(nominal(rotate), 1, backend="mujoco", source="main", seed=1)
    for _ in range(steps):
        env.step(torch.as_tensor(act(env.observe()[0].numpy())))
    return env.joint_pos()[0].tolist()


def deployed(policy: Path, work: Path) -> dict[str, Any]:
    why = why_not()
    if why:
        pytest.skip(why)
    python = shlex.quote(str(PYTHON))
    command = f"{python} -m svhdesc.cli deploy svh_rotate --policy {shlex.quote(str(policy))} --duration {DURATION}"
    script = f"ip link set lo up && cd {shlex.quote(str(work))} && exec {command} --seed 1"
    namespace = private_namespace()
    assert isinstance(namespace, list)
    result = subprocess.run(
        [*namespace, "sh", "-c", script], env=private_env(work), capture_output=True, text=True, timeout=600
    )
    lines = [line for line in result.stdout.splitlines() if line.startswith("{")]
    assert result.returncode == 0 and lines, f"exit {result.returncode}\n{result.stdout[-2000:]}{result.stderr[-3000:]}"
    assert "Traceback" not in result.stderr, result.stderr[-3000:]
    return json.loads(lines[-1])


def test_policy_drives_the_ros2_node_as_in_process(policy: Path, tmp_path: Path) -> None:
    verdict = deployed(policy, tmp_path)
    steps = round(DURATION * 25.0)
    assert verdict["ticks"] == steps and verdict["steps"] == steps, verdict
    assert verdict["controllers"] == ["forward_position_controller"]
    assert verdict["score_name"] == "yaw rate (rad/s)" and np.isfinite(verdict["score"])
    reference = in_process(policy, steps)
    gap = np.abs(np.array(verdict["joints"]) - np.array(reference))
    print(f"channels through ROS 2 vs in process: {gap.max():.4f} rad at most", file=sys.stderr)
    assert gap.max() < BOUND, (verdict["joints"], reference)
