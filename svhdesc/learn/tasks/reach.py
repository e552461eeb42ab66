"""``svh_reach``: the fixed hand puts its five fingertips where a random reachable hand pose puts them.

Small enough to learn on two CPU cores in minutes: the suite's learning test trains it. A target is drawn per episode
as the fingertip positions of uniformly drawn channel positions (couplings applied), so every target is reachable.
Success: the five fingertips within 1 cm of their targets on average at the episode's end.
"""

from __future__ import annotations

from typing import Any

import torch

from svhdesc.batch.env import fingertip_bodies
from svhdesc.learn.spec import Actions, Obs, Randomisation, Reward, Scene, Task, Training

TOLERANCE = 0.01  # m, mean fingertip error at the end that counts as success


def _tips(env: Any) -> list[int]:
    if "tips" not in env.commands:
        env.commands["tips"] = torch.tensor(fingertip_bodies(env.mjm), device=env.device)
    return env.commands["tips"]


def tip_pos(env: Any) -> torch.Tensor:
    """[nenv, 5, 3] fingertip positions."""
    return env.physics.state["xpos"][:, _tips(env)]


def tip_error(env: Any) -> torch.Tensor:
    """Mean distance (m) of the fingertips from their targets."""
    return torch.linalg.norm(tip_pos(env) - env.commands["target"], dim=-1).mean(-1)


def reset(env: Any, mask: torch.Tensor) -> None:
    low, high = env.ctrl_low, env.ctrl_high
    goal = low + (high - low) * env.uniform(0.0, 1.0, env.num_actions)
    env.set_joints(mask, goal)
    env.physics.kinematics()
    target = env.commands.get("target", torch.zeros_like(tip_pos(env)))
    env.commands["target"] = torch.where(mask.view(-1, 1, 1), tip_pos(env), target)
    start = low + (high - low) * env.uniform(0.0, 0.2, env.num_actions)
    env.set_joints(mask, start)


def _reach(env: Any) -> torch.Tensor:
    return torch.exp(-tip_error(env) / 0.02)


def _action_rate(env: Any) -> torch.Tensor:
    return torch.square(env.action - env.previous_action).sum(-1)


TASK = Task(
    name="svh_reach",
    summary="svh_right puts its five fingertips on the targets of a random reachable pose",
    scene=Scene(variant="svh_right", physics_dt=0.005, contacts=False, nconmax=104, njmax=64),
    control_hz=25.0,
    episode_s=1.6,
    actions=Actions(scale=0.5, default={}),
    actor=(
        Obs("joint_pos", lambda env: env.joint_pos(), noise=0.005, sensed=True),
        Obs("last_action", lambda env: env.action),
        Obs("target", lambda env: env.commands["target"]),
    ),
    critic=(
        Obs("joint_pos", lambda env: env.joint_pos()),
        Obs("joint_vel", lambda env: env.joint_vel()),
        Obs("last_action", lambda env: env.action),
        Obs("target", lambda env: env.commands["target"]),
        Obs("tips", tip_pos),
    ),
    rewards=(Reward("reach", _reach, 1.0), Reward("action_rate", _action_rate, -0.01)),
    dones=(),
    reset=reset,
    success=lambda env: tip_error(env) < TOLERANCE,
    randomisation=Randomisation(servo_gain=(0.9, 1.1), joint_damping=(0.9, 1.1), latency=(0, 1)),
    training=Training(steps_per_env=16, hidden=(128, 128), learning_rate=1e-3, entropy=0.002, init_noise=0.6),
    score=lambda env: tip_error(env) * 1000.0,
    camera=((0.0, -0.01, 0.12), 0.35, 150.0, -20.0),
    score_name="fingertip error at the end (mm)",
)
