"""TaskEnv's mechanics: actions become clipped, ramped servo targets; sensed observations arrive as late as each
world's latency; a reset touches only its worlds; the Warp backend's tensors are Warp's own memory and step like
MuJoCo C.

Seeded faults, each failing the test named: the ramp's ``self.ramp`` replaced by infinity
(test_targets_are_clipped_and_ramped); ``_late`` returning the newest row (test_sensed_observations_lag);
``where_rows`` ignoring its mask (test_reset_touches_only_its_worlds); ``WarpPhysics.state`` built from
``.numpy()`` copies (test_warp_tensors_are_warps_memory); the Warp model's per-world fields not batched
(``batched=()`` in WarpPhysics: test_warp_tensors_are_warps_memory fails on the model view's shape).
"""

from __future__ import annotations

import dataclasses

import pytest
import torch

pytest.importorskip("torch")

from svhdesc.errors import SvhdescError  # noqa: E402
from svhdesc.learn import task  # noqa: E402
from svhdesc.learn.env import TaskEnv  # noqa: E402
from svhdesc.learn.tasks import reach  # noqa: E402


def test_targets_are_clipped_and_ramped() -> None:
    env = TaskEnv(task("svh_reach"), 2, backend="mujoco", seed=1)
    before = env.physics.state["ctrl"].clone()
    env.step(torch.full((2, env.num_actions), 100.0))
    after = env.physics.state["ctrl"]
    assert torch.all(after <= env.ctrl_high + 1e-6)
    moved = (after - before).abs()
    assert torch.all(moved <= env.ramp + 1e-6), (moved, env.ramp)  # the firmware's ramp: one period's worth
    assert torch.all(moved[:, env.ramp < (env.ctrl_high - env.ctrl_low)] > 0)
    for _ in range(34):  # within the episode (40 steps): the channels whose ramp is fast enough reach the top
        env.step(torch.full((2, env.num_actions), 100.0))
    fast = 35 * env.ramp >= env.ctrl_high - env.ctrl_low + 0.05
    ctrl = env.physics.state["ctrl"]
    assert fast.any() and (~fast).any()
    assert torch.allclose(ctrl[:, fast], env.ctrl_high[fast].expand(2, -1))
    assert torch.all(ctrl[:, ~fast] < env.ctrl_high[~fast])


def test_sensed_observations_lag() -> None:
    quiet = dataclasses.replace(
        task("svh_reach"), randomisation=dataclasses.replace(task("svh_reach").randomisation, noise=0.0, latency=(2, 2))
    )
    env = TaskEnv(quiet, 2, backend="mujoco", seed=1)
    nu = env.num_actions
    positions = []
    for k in range(6):
        actor, _ = env.observe()
        positions.append(env.joint_pos().clone())
        if k >= 2:
            assert torch.allclose(actor[:, :nu], positions[k - 2], atol=1e-6)
            assert not torch.allclose(actor[:, :nu], positions[k], atol=1e-4)
        env.step(torch.full((2, nu), 1.0))


def test_reset_touches_only_its_worlds() -> None:
    env = TaskEnv(task("svh_reach"), 3, backend="mujoco", seed=1)
    for _ in range(5):
        env.step(torch.full((3, env.num_actions), 0.5))
    kept = env.qpos[1].clone(), env.commands["target"][1].clone(), env.episode_length_buf[1].item()
    env._reset(torch.tensor([True, False, True]))
    assert torch.equal(env.qpos[1], kept[0]) and torch.equal(env.commands["target"][1], kept[1])
    assert env.episode_length_buf.tolist() == [0, kept[2], 0]


def test_bad_arguments() -> None:
    with pytest.raises(SvhdescError, match="at least 1"):
        TaskEnv(task("svh_reach"), 0, backend="mujoco")
    with pytest.raises(SvhdescError, match="unknown physics backend"):
        TaskEnv(task("svh_reach"), 1, backend="bullet")
    with pytest.raises(SvhdescError, match="unknown task 'svh_juggle'"):
        task("svh_juggle")


@pytest.mark.slow
def test_warp_tensors_are_warps_memory() -> None:
    pytest.importorskip("mujoco_warp")
    env = TaskEnv(task("svh_reach"), 2, device="cpu", backend="warp", seed=1)
    batch = env.physics.batch
    qpos = env.physics.state["qpos"]
    assert qpos.data_ptr() == batch.data.qpos.ptr  # a view, not a copy
    qpos[1, 0] = 0.123
    assert abs(float(batch.data.qpos.numpy()[1, 0]) - 0.123) < 1e-7
    friction = env.physics.model["geom_friction"]
    assert friction.shape[0] == 2 and friction.data_ptr() == batch.model.geom_friction.ptr


@pytest.mark.slow
def test_warp_steps_like_mujoco_c() -> None:
    """The same task, seed and actions on Warp's CPU device and in MuJoCo C (the batch model both): the index
    fingertip within 2 mm after 1 s (no contact in this task: only float32 against float64)."""
    pytest.importorskip("mujoco_warp")
    envs = [TaskEnv(task("svh_reach"), 2, device="cpu", backend=b, seed=7) for b in ("warp", "mujoco")]
    generator = torch.Generator().manual_seed(0)
    for _ in range(25):
        action = torch.randn(2, envs[0].num_actions, generator=generator)
        for env in envs:
            env.step(action)
    warp, c = (reach.tip_pos(env) for env in envs)
    assert torch.allclose(warp.double(), c.double(), atol=2e-3), (warp, c)


@pytest.mark.slow
@pytest.mark.parametrize("name", ["svh_rotate", "ur5_lift"])
def test_warp_runs_the_contact_tasks_within_their_capacities(name: str) -> None:
    """The contact tasks on Warp's CPU device: per-world randomised objects, 5 control periods of random actions,
    no overflow of the capacities the task states (BatchOverflow otherwise), every world still finite; the objects
    where MuJoCo C puts them from the same reset (2 mm after the first period). Seeded faults: CPhysics not writing a
    resized object's dof_M0 (the cube falls at 0.71 g in MuJoCo C) or its BVH box (the grown box sinks 9 mm into the
    table before MuJoCo C's broadphase finds it): each fails here."""
    pytest.importorskip("mujoco_warp")
    envs = [TaskEnv(task(name), 2, device="cpu", backend=b, seed=4) for b in ("warp", "mujoco")]
    sizes = [env.physics.model["geom_size"][:, env.geom_id(env.task.scene.objects[0].name)] for env in envs]
    assert torch.allclose(sizes[0].double(), sizes[1].double(), atol=1e-6) and not torch.equal(sizes[0][0], sizes[0][1])
    generator = torch.Generator().manual_seed(1)
    for period in range(5):
        action = 0.5 * torch.randn(2, envs[0].num_actions, generator=generator)
        for env in envs:
            env.step(action)
        if period == 0:
            name0 = envs[0].task.scene.objects[0].name
            warp, c = (env.object_pos(name0).double() for env in envs)
            assert torch.allclose(warp, c, atol=2e-3), (warp, c)
    envs[0].physics.check_overflow()
    assert not envs[0].physics.diverged().any() and torch.isfinite(envs[0].qpos).all()
