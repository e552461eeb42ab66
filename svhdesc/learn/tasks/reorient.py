"""``svh_reorient``: ``svh_right`` palm up turns a cube to random target orientations, one after another.

MuJoCo Playground's LeapCubeReorient and Isaac Lab's in-hand reorientation are the references: a target drawn
uniformly over all orientations; reached when the cube is within ``THRESHOLD`` (0.1 rad, both of theirs) of it,
then a new one is drawn at once; the episode's score is the number of targets reached (Playground's success count,
Isaac Lab's consecutive successes), its success that at least one was. Dropping the cube ends the episode. The scene,
actions and randomisation are svh_rotate's; the actor also sees the rotation from the target to the cube.
"""

from __future__ import annotations

import dataclasses
from typing import Any

import torch

from svhdesc.learn import mdp
from svhdesc.learn.spec import Done, Obs, Reward
from svhdesc.learn.tasks import rotate

THRESHOLD = 0.1  # rad: Playground's and Isaac Lab's success tolerance


def orientation_error(env: Any) -> torch.Tensor:
    return mdp.rotation_angle(env.object_quat("cube"), env.commands["goal"])


def to_goal(env: Any) -> torch.Tensor:
    """The rotation from the target to the cube, as two rotation-matrix columns (zero error: the identity's)."""
    return mdp.rot6d(mdp.quat_mul(env.object_quat("cube"), mdp.quat_conj(env.commands["goal"])))


def _new_goals(env: Any, mask: torch.Tensor) -> None:
    goal = mdp.random_quat(env.num_envs, env.generator, env.device)
    env.commands["goal"] = torch.where(mask.unsqueeze(-1), goal, env.commands.get("goal", goal))


def reset(env: Any, mask: torch.Tensor) -> None:
    rotate.place_cube(env, mask)
    _new_goals(env, mask)
    reached = env.commands.get("reached", torch.zeros(env.num_envs, device=env.device))
    env.commands["reached"] = torch.where(mask, torch.zeros_like(reached), reached)
    env.commands["hit"] = torch.zeros(env.num_envs, dtype=torch.bool, device=env.device)


def update(env: Any) -> None:
    """Count a reached target and draw the next one at once."""
    hit = orientation_error(env) < THRESHOLD
    env.commands["hit"] = hit
    env.commands["reached"] = env.commands["reached"] + hit.float()
    _new_goals(env, hit)


def _orientation(env: Any) -> torch.Tensor:
    """Playground's tolerance: 1 within 0.2 rad, falling linearly to 0 at pi."""
    return torch.clamp(1.0 - (orientation_error(env) - 0.2) / (torch.pi - 0.2), 0.0, 1.0)


TASK = dataclasses.replace(
    rotate.TASK,
    name="svh_reorient",
    summary="svh_right palm up turns a cube to random target orientations, one after another",
    actor=(
        *rotate.TASK.actor,
        Obs("to_goal", to_goal, noise=0.05, sensed=True),
    ),
    critic=(*rotate.TASK.critic, Obs("to_goal", to_goal)),
    rewards=(
        Reward("orientation", _orientation, 5.0),
        Reward("reached", lambda env: env.commands["hit"].float() / env.dt, 100.0),  # 100 a target, as Playground
        Reward("off_palm", lambda env: torch.linalg.norm(rotate.cube_offset(env), dim=-1), -1.0),
        Reward("dropped", lambda env: rotate.dropped(env).float(), -100.0),
        Reward("action_rate", lambda env: torch.square(env.action - env.previous_action).sum(-1), -0.001),
    ),
    dones=(Done("dropped", rotate.dropped),),
    reset=reset,
    update=update,
    success=lambda env: (env.commands["reached"] >= 1) & ~rotate.dropped(env),
    score=lambda env: env.commands["reached"],
    score_name="targets reached",
)
