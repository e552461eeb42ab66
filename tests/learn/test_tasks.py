"""Every task's rewards, terminations, successes and resets, checked by placing states by hand (MuJoCo C backend).

Seeded faults, each failing the test named: ``rotate.dropped`` returning all False (the cube below the palm is not
a termination: test_rotate_drop_terminates_and_fails); the yaw-rate reward's clip made ``clamp(rate, 0, MAX)``
(a cube turned the other way is rewarded 0, not penalised: test_rotate_rewards_turning_about_z); ``lift.update``
not resetting ``held`` when the object leaves the target (test_lift_success_needs_a_second_held); the lift reset
parking the active shape too (test_lift_reset_one_object_on_the_table); the reach target drawn from the start pose
instead of the goal (test_reach_success_at_target); the randomised cube mass ignored (test_rotate_reset_randomises);
reorient's ``update`` keeping a reached target (test_reorient_counts_a_reached_target_and_draws_the_next); the
rotate score divided by the time the episode lasted, not the episode's duration (test_rotate_score_of_an_early_drop);
the episodes' mean score taken over the diverged ones too (test_a_diverged_episode_scores_nothing).
"""

from __future__ import annotations

import math

import pytest
import torch

pytest.importorskip("torch")
pytest.importorskip("mujoco")

from svhdesc.learn import task  # noqa: E402
from svhdesc.learn.env import TaskEnv  # noqa: E402
from svhdesc.learn.tasks import lift, reach, reorient, rotate  # noqa: E402


def _everyone(env: TaskEnv) -> torch.Tensor:
    return torch.ones(env.num_envs, dtype=torch.bool)


def _step(env: TaskEnv, n: int = 1) -> tuple[torch.Tensor, torch.Tensor, dict]:
    for _ in range(n):
        _, reward, done, extras = env.step(torch.zeros(env.num_envs, env.num_actions))
    return reward, done, extras


@pytest.fixture(scope="module")
def rotate_env() -> TaskEnv:
    return TaskEnv(task("svh_rotate"), 4, backend="mujoco", seed=3)


def test_rotate_reset_puts_the_cube_on_the_palm(rotate_env: TaskEnv) -> None:
    env = rotate_env
    env.reset()
    offset = rotate.cube_offset(env)
    assert torch.all(offset[:, :2].abs() <= 0.0051), offset
    assert not rotate.dropped(env).any()
    _, done, _ = _step(env, 10)  # 0.4 s at the default pose: the cube settles, nobody drops it
    assert not done.any()


def test_rotate_reset_randomises(rotate_env: TaskEnv) -> None:
    env = rotate_env
    env.reset()
    r = env.task.randomisation
    geom, body = env.geom_id("cube"), env.bodies["cube"]
    size = env.physics.model["geom_size"][:, geom, 0] / rotate.CUBE.size[0]
    mass = env.physics.model["body_mass"][:, body]
    friction = env.physics.model["geom_friction"][:, geom, 0]
    kp = env.physics.model["actuator_gainprm"][:, 0, 0] / env.nominal["actuator_gainprm"][:, 0, 0]
    for values, (low, high) in ((size, r.object_scale), (mass, r.object_mass), (friction, r.object_friction)):
        assert torch.all((values >= low - 1e-6) & (values <= high + 1e-6)), values
        assert len(set(values.tolist())) == env.num_envs  # each world its own draw
    assert torch.all((kp >= r.servo_gain[0] - 1e-6) & (kp <= r.servo_gain[1] + 1e-6))
    bias = env.physics.model["actuator_biasprm"][:, 0, 1]
    assert torch.allclose(bias, -env.physics.model["actuator_gainprm"][:, 0, 0])  # a position servo stays one


def _spin(env: TaskEnv, rate: float) -> None:
    adr = env.free["cube"][1]
    qvel = env.qvel
    qvel[:, adr + 3 : adr + 6] = torch.tensor((0.0, 0.0, rate))  # body frame; the cube lies flat: z is z


def test_rotate_rewards_turning_about_z(rotate_env: TaskEnv) -> None:
    env = rotate_env
    terms = {r.name: r for r in env.task.rewards}
    for rate in (1.5, -1.5):
        env.reset()
        _spin(env, rate)
        value = terms["yaw_rate"].fn(env)
        assert torch.allclose(value, torch.full_like(value, rate), atol=0.05), value
    env.reset()
    _spin(env, 10.0)
    assert torch.allclose(terms["yaw_rate"].fn(env), torch.full((env.num_envs,), rotate.MAX_RATE), atol=0.05)


def test_rotate_drop_terminates_and_fails(rotate_env: TaskEnv) -> None:
    env = rotate_env
    env.reset()
    env.stats.clear()
    below = rotate.palm(env) + torch.tensor((0.0, 0.0, -0.15))
    env.set_object(_everyone(env), "cube", below.expand(env.num_envs, 3), env.object_quat("cube").clone())
    env.physics.kinematics()
    assert rotate.dropped(env).all()
    reward, done, extras = _step(env)
    assert done.all() and not extras["time_outs"].any()
    stats = env.stats.read()
    assert stats["failure"] == 1.0 and stats["success"] == 0.0
    assert torch.all(reward < -50 * env.dt)  # the drop's -100 per second
    assert not rotate.dropped(env).any()  # and every world was reset


def test_rotate_score_of_an_early_drop(rotate_env: TaskEnv) -> None:
    """A cube spinning at 10 rad/s as it falls in the first control step scores the yaw it turned spread over the
    whole episode (10 rad/s for one 40 ms step of a 10 s episode: 0.04 rad/s), not 10 rad/s."""
    env = rotate_env
    env.reset()
    env.stats.clear()
    _spin(env, 10.0)
    env.task.update(env)
    below = rotate.palm(env) + torch.tensor((0.0, 0.0, -0.15))
    env.set_object(_everyone(env), "cube", below.expand(env.num_envs, 3), env.object_quat("cube").clone())
    env.physics.kinematics()
    _step(env)
    score = env.stats.read()["score"]
    assert score == pytest.approx(10.0 * env.dt / env.task.episode_s, rel=0.05), score


def test_a_diverged_episode_scores_nothing(rotate_env: TaskEnv) -> None:
    """Two worlds blow up (their cubes flung at 2000 m/s, spinning at 2000 rad/s: diverged, failed), two drop their
    cube: the episodes' score is the dropped ones' (0 rad/s), not a mean the flung cubes' yaw outweighs."""
    env = rotate_env
    env.reset()
    env.stats.clear()
    flung = torch.tensor([True, True, False, False])
    adr = env.free["cube"][1]
    env.qvel[:2, adr : adr + 6] = torch.tensor((0.0, 0.0, 2000.0, 0.0, 0.0, 2000.0))
    below = rotate.palm(env) + torch.tensor((0.0, 0.0, -0.15))
    env.set_object(~flung, "cube", below.expand(env.num_envs, 3), env.object_quat("cube").clone())
    env.physics.kinematics()
    reward, done, _ = _step(env)
    stats = env.stats.read()
    assert done.all() and stats["diverged"] == 0.5 and stats["failure"] == 1.0, stats
    assert torch.equal(reward[:2], torch.zeros(2)), reward  # a blown-up world's reward would swamp PPO's update
    assert stats["score"] == pytest.approx(0.0, abs=0.01), stats


@pytest.fixture(scope="module")
def lift_env() -> TaskEnv:
    return TaskEnv(task("ur5_lift"), 6, backend="mujoco", seed=4)


def test_lift_reset_one_object_on_the_table(lift_env: TaskEnv) -> None:
    env = lift_env
    env.reset()
    shapes = env.commands["shape"]
    assert set(shapes.tolist()) == {0, 1, 2}  # with this seed, every shape is drawn
    for k, shape in enumerate(lift.SHAPES):
        pos = env.object_pos(shape.name)
        gravcomp = env.physics.model["body_gravcomp"][:, env.bodies[shape.name]]
        active = shapes == k
        assert torch.all(pos[active, 2] < lift.TABLE_TOP + 0.05) and torch.all(pos[active, 2] > lift.TABLE_TOP)
        assert torch.all(pos[~active, 0] >= 2.0) and torch.all(gravcomp[~active] == 1.0)
        assert torch.all(gravcomp[active] == 0.0)
    size = env.physics.model["geom_size"][:, [env.geom_id(s.name) for s in lift.SHAPES], 0]
    across = 2 * size[torch.arange(env.num_envs), shapes]
    assert torch.all((across >= 0.04 - 1e-6) & (across <= 0.08 + 1e-6)), across
    mass = env.physics.model["body_mass"][:, [env.bodies[s.name] for s in lift.SHAPES]]
    assert torch.all((mass >= 0.05 - 1e-6) & (mass <= 0.5 + 1e-6))
    _, done, _ = _step(env, 10)  # nothing falls off at the start pose
    assert not done.any()


def _float_at(env: TaskEnv, where: torch.Tensor) -> None:
    """Hold every world's object at ``where``: weightless, still."""
    mask = _everyone(env)
    for k, shape in enumerate(lift.SHAPES):
        active = env.commands["shape"] == k
        pos = torch.where(active.unsqueeze(-1), where, env.object_pos(shape.name))
        env.set_object(mask, shape.name, pos, env.object_quat(shape.name).clone())
        env.set_model(mask, "body_gravcomp", env.bodies[shape.name], torch.ones(env.num_envs))
    env.physics.commit_model()
    env.physics.kinematics()


def test_lift_success_needs_a_second_held(lift_env: TaskEnv) -> None:
    env = lift_env
    env.reset()
    _float_at(env, env.commands["target"].clone())
    steps = math.ceil(lift.HOLD * env.task.control_hz)
    _step(env, steps - 2)
    assert not env.task.success(env).any()  # not yet a second
    _step(env, 2)
    assert env.task.success(env).all()
    _float_at(env, env.commands["target"] + torch.tensor((0.0, 0.0, 0.2)))  # away: the count starts again
    _step(env)
    assert not env.task.success(env).any() and torch.all(env.commands["held"] == 0)


def test_lift_object_on_the_table_is_no_success(lift_env: TaskEnv) -> None:
    env = lift_env
    env.reset()
    _step(env, math.ceil(lift.HOLD * env.task.control_hz) + 1)
    assert not env.task.success(env).any()
    assert torch.all(torch.linalg.norm(lift.to_target(env), dim=-1) > 0.08)


def test_lift_knocked_off_terminates(lift_env: TaskEnv) -> None:
    env = lift_env
    env.reset()
    env.stats.clear()
    _float_at(env, env.commands["target"] + torch.tensor((0.5, 0.0, -0.15)))
    assert lift.fell(env).all()
    _, done, extras = _step(env)
    assert done.all() and not extras["time_outs"].any() and env.stats.read()["failure"] == 1.0


def test_reach_success_at_target() -> None:
    env = TaskEnv(task("svh_reach"), 4, backend="mujoco", seed=5)
    assert torch.all(reach.tip_error(env) > reach.TOLERANCE)  # starts away from its target
    goal = env.commands["target"].clone()
    # the pose that made the target: search it back by driving the servos there (targets are reachable)
    env.set_joints(_everyone(env), env.commands["goal"])
    env.physics.kinematics()
    assert torch.allclose(reach.tip_pos(env), goal, atol=1e-5)
    assert env.task.success(env).all()
    terms = {r.name: r for r in env.task.rewards}
    assert torch.allclose(terms["reach"].fn(env), torch.ones(env.num_envs), atol=1e-3)


def test_reorient_counts_a_reached_target_and_draws_the_next() -> None:
    """The cube turned onto its target: one target reached, 100 of reward for it, a new target at once; the
    score counts them. Seeded fault: ``update`` not drawing a new target (the same one is counted every step)."""
    env = TaskEnv(task("svh_reorient"), 3, backend="mujoco", seed=6)
    goal = env.commands["goal"].clone()
    assert torch.all(reorient.orientation_error(env) > reorient.THRESHOLD)
    env.set_object(_everyone(env), "cube", env.object_pos("cube").clone(), goal)
    env.physics.kinematics()
    env.task.update(env)
    assert torch.equal(env.commands["reached"], torch.ones(3)) and env.commands["hit"].all()
    assert not torch.allclose(env.commands["goal"], goal)
    terms = {r.name: r for r in env.task.rewards}
    assert torch.allclose(terms["reached"].fn(env) * terms["reached"].weight * env.dt, torch.full((3,), 100.0))
    env.task.update(env)  # the cube has not moved: the new target is not reached
    assert torch.equal(env.commands["reached"], torch.ones(3)) and not env.commands["hit"].any()
    assert torch.equal(env.task.score(env), torch.ones(3)) and env.task.success(env).all()
