"""``svh_reach``: the fixed hand puts its index fingertip on a target point.

Small enough to learn on two CPU cores in minutes: the suite's learning test trains it. A target is drawn per episode
as the index fingertip's position in uniformly drawn channel positions (couplings applied), so every target is
reachable. Nothing is touched, so the scene has no contacts and a 10 ms physics step (the servos alone). Success:
the fingertip within 1 cm of its target at the episode's end.
"""

from __future__ import annotations

from typing import Any

import torch

from svhdesc.batch.env import fingertip_bodies
from svhdesc.learn.spec import Actions, Obs, Randomisation, Reward, Scene, Task, Training

TOLERANCE = 0.01  # m, fingertip error at the end that counts as success
FINGER = "Index_Finger_Proximal"  # the channel whose finger reaches


def fingertip(model: Any, hand: Any) -> int:
    """The fingertip body on the chain of the joint driven by the ``FINGER`` channel (``hand``: the built model's
    HandId, which names it)."""
    joint = hand.name(FINGER)
    for tip in fingertip_bodies(model):
        body = tip
        while body > 0:
            joints = [model.joint(int(model.body_jntadr[body]) + k).name for k in range(int(model.body_jntnum[body]))]
            if joint in joints:
                return tip
            body = int(model.body_parentid[body])
    raise ValueError(f"no fingertip below joint {joint}")


def tip_pos(env: Any) -> torch.Tensor:
    if "tip" not in env.commands:
        env.commands["tip"] = torch.tensor(fingertip(env.mjm, env.hand), device=env.device)
    return env.physics.state["xpos"][:, env.commands["tip"]]


def tip_error(env: Any) -> torch.Tensor:
    """Distance (m) of the fingertip from its target."""
    return torch.linalg.norm(tip_pos(env) - env.commands["target"], dim=-1)


def reset(env: Any, mask: torch.Tensor) -> None:
    low, high = env.ctrl_low, env.ctrl_high
    goal = low + (high - low) * env.uniform(0.0, 1.0, env.num_actions)
    env.set_joints(mask, goal)
    env.physics.kinematics()
    target = env.commands.get("target", torch.zeros_like(tip_pos(env)))
    env.commands["target"] = torch.where(mask.unsqueeze(-1), tip_pos(env), target)
    env.commands["goal"] = torch.where(mask.unsqueeze(-1), goal, env.commands.get("goal", goal))  # what made it
    start = low + (high - low) * env.uniform(0.0, 0.2, env.num_actions)
    env.set_joints(mask, start)


def _reach(env: Any) -> torch.Tensor:
    return torch.exp(-tip_error(env) / 0.02)


def _action_rate(env: Any) -> torch.Tensor:
    return torch.square(env.action - env.previous_action).sum(-1)


TASK = Task(
    name="svh_reach",
    summary="svh_right puts its index fingertip on a random reachable target",
    scene=Scene(variant="svh_right", physics_dt=0.01, contacts=False, nconmax=104, njmax=64),
    control_hz=25.0,
    episode_s=1.6,
    actions=Actions(scale=0.5, default={}),
    actor=(
        Obs("joint_pos", lambda env: env.joint_pos(), noise=0.005, sensed=True),
        Obs("last_action", lambda env: env.action),
        Obs("target", lambda env: env.commands["target"]),
        Obs("to_target", lambda env: env.commands["target"] - tip_pos(env)),
    ),
    critic=(
        Obs("joint_pos", lambda env: env.joint_pos()),
        Obs("joint_vel", lambda env: env.joint_vel()),
        Obs("last_action", lambda env: env.action),
        Obs("target", lambda env: env.commands["target"]),
        Obs("to_target", lambda env: env.commands["target"] - tip_pos(env)),
    ),
    rewards=(Reward("reach", _reach, 1.0), Reward("action_rate", _action_rate, -0.01)),
    dones=(),
    reset=reset,
    success=lambda env: tip_error(env) < TOLERANCE,
    randomisation=Randomisation(servo_gain=(0.9, 1.1), joint_damping=(0.9, 1.1), latency=(0, 1)),
    training=Training(steps_per_env=16, hidden=(128, 128), learning_rate=1e-3, entropy=0.002, init_noise=0.6),
    markers=lambda env: env.commands["target"].unsqueeze(1),
    camera=((0.0, 0.0, 0.13), 0.32, -120.0, -15.0),
    score=lambda env: tip_error(env) * 1000.0,
    score_name="fingertip error at the end (mm)",
)
