"""mjlab terms for the SVH tasks (functions of mjlab's ``ManagerBasedRlEnv``), beside mjlab's own
(``mjlab.envs.mdp``, ``mjlab.tasks.manipulation.mdp``). Quaternions are (w, x, y, z) in both libraries."""

from __future__ import annotations

from typing import Any

import torch

from svhdesc.learn import mdp as shared
from svhdesc.model import Coupling


def object_offset(env: Any, object_name: str, rest: tuple[float, float, float]) -> torch.Tensor:
    """The object's position relative to ``rest`` (in its world's frame)."""
    pos = env.scene[object_name].data.root_link_pos_w - env.scene.env_origins
    return pos - torch.tensor(rest, device=env.device)


def object_rot6d(env: Any, object_name: str) -> torch.Tensor:
    """The object's orientation as the first two columns of its rotation matrix."""
    return shared.rot6d(env.scene[object_name].data.root_link_quat_w)


def object_lin_vel(env: Any, object_name: str) -> torch.Tensor:
    return env.scene[object_name].data.root_link_lin_vel_w


def object_ang_vel(env: Any, object_name: str) -> torch.Tensor:
    return env.scene[object_name].data.root_link_ang_vel_w


def yaw_rate(env: Any, object_name: str, limit: float) -> torch.Tensor:
    """The object's angular velocity about world z, clipped to +-``limit`` (rad/s)."""
    return torch.clamp(object_ang_vel(env, object_name)[:, 2], -limit, limit)


def off_rest(env: Any, object_name: str, rest: tuple[float, float, float]) -> torch.Tensor:
    return torch.linalg.norm(object_offset(env, object_name, rest), dim=-1)


def dropped(env: Any, object_name: str, rest: tuple[float, float, float], distance: float) -> torch.Tensor:
    """The object ``distance`` below its resting place, or that far off it sideways."""
    offset = object_offset(env, object_name, rest)
    return (offset[:, 2] < -distance) | (torch.linalg.norm(offset[:, :2], dim=-1) > distance)


def dropped_penalty(env: Any, object_name: str, rest: tuple[float, float, float], distance: float) -> torch.Tensor:
    return dropped(env, object_name, rest, distance).float()


def below(env: Any, object_name: str, height: float) -> torch.Tensor:
    """The object's centre below ``height`` (m, in its world's frame): it fell off the table."""
    pos = env.scene[object_name].data.root_link_pos_w - env.scene.env_origins
    return pos[:, 2] < height


def follow(coupling: Coupling, leader: torch.Tensor) -> torch.Tensor:
    """Where the coupling puts its follower for the leader's positions (the polynomial, evaluated in torch)."""
    return sum((c * leader**k for k, c in enumerate(coupling.coeffs)), torch.zeros_like(leader))


def reset_coupled_joints(
    env: Any, env_ids: torch.Tensor | None, jitter: float, couplings: tuple[Coupling, ...], robot: str = "robot"
) -> None:
    """Each actuated joint at its default plus a uniform jitter of +-``jitter`` rad (within its limits), every
    coupled joint where its coupling puts it: a reset that starts with the couplings satisfied (mjlab's
    ``reset_joints_by_offset`` moves each joint on its own, a follower off its leader)."""
    entity = env.scene[robot]
    ids = torch.arange(env.num_envs, device=env.device) if env_ids is None else env_ids
    pos = entity.data.default_joint_pos[ids].clone()
    names = list(entity.joint_names)
    followers = {c.joint for c in couplings}
    free = [i for i, name in enumerate(names) if name not in followers]
    pos[:, free] += (torch.rand(len(ids), len(free), device=env.device) * 2.0 - 1.0) * jitter
    limits = entity.data.soft_joint_pos_limits[ids]
    pos = torch.clamp(pos, limits[..., 0], limits[..., 1])
    for coupling in couplings:
        pos[:, names.index(coupling.joint)] = follow(coupling, pos[:, names.index(coupling.leader)])
    entity.write_joint_state_to_sim(pos, torch.zeros_like(pos), env_ids=ids)


def coupling_residual(entity: Any, couplings: tuple[Coupling, ...]) -> torch.Tensor:
    """Per world, the largest |q_follower - polynomial(q_leader)| over the couplings (rad)."""
    names = list(entity.joint_names)
    q = entity.data.joint_pos
    gaps = [torch.abs(q[:, names.index(c.joint)] - follow(c, q[:, names.index(c.leader)])) for c in couplings]
    return torch.stack(gaps, -1).amax(-1) if gaps else torch.zeros(q.shape[0], device=q.device)


def below_penalty(env: Any, object_name: str, height: float) -> torch.Tensor:
    return below(env, object_name, height).float()
