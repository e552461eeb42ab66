"""The stack learns: ``svh_reach`` trained for ``ITERATIONS`` PPO iterations on two CPU cores (MuJoCo C backend, 64
worlds) puts the index fingertip nearer its targets than the untrained actor (action 0: the hand stays near its
start), on the same 64 evaluation episodes.

Bound: the trained actor's mean final error is at most ``MARGIN`` x the untrained one's. Measured when the test was
written (a 2-core machine shared with other jobs, 137 s): untrained 44.8 mm, trained 31.4 mm (0.70). Seeded
fault: the reach reward's sign flipped (``Reward("reach", _reach, -1.0)``): untrained 44.8 mm, trained 44.8 mm
(1.00), the test fails.
"""

from __future__ import annotations

from pathlib import Path

import pytest

pytest.importorskip("torch")
pytest.importorskip("rsl_rl")
pytest.importorskip("onnxruntime")

from svhdesc.learn import task  # noqa: E402
from svhdesc.learn.env import TaskEnv  # noqa: E402
from svhdesc.learn.policy import OnnxPolicy, evaluate, zero_policy  # noqa: E402
from svhdesc.learn.train import train  # noqa: E402

pytestmark = pytest.mark.slow

ITERATIONS = 30
MARGIN = 0.8
EPISODES = 64


def test_reach_learns(tmp_path: Path) -> None:
    reach = task("svh_reach")
    env = TaskEnv(reach, 64, backend="mujoco", seed=0)
    last = train(reach, env, tmp_path, minutes=None, iterations=ITERATIONS, seed=0, say=print)
    policy = OnnxPolicy(last.parent / "policy.onnx", reach)
    trained = evaluate(TaskEnv(reach, EPISODES, backend="mujoco", seed=123), policy, EPISODES)
    untrained = evaluate(TaskEnv(reach, EPISODES, backend="mujoco", seed=123), zero_policy(env.num_actions), EPISODES)
    print(f"fingertip error: untrained {untrained.score:.1f} mm, trained {trained.score:.1f} mm")
    assert trained.score <= MARGIN * untrained.score, (trained, untrained)
