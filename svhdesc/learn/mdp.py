"""Terms and helpers tasks share: quaternion arithmetic (MuJoCo's order w, x, y, z) and common observations,
rewards and resets, each a function of a running ``TaskEnv`` returning one row per world."""

from __future__ import annotations

import math
from typing import Any

import torch

Tensor = torch.Tensor


def quat_mul(a: Tensor, b: Tensor) -> Tensor:
    aw, ax, ay, az = a.unbind(-1)
    bw, bx, by, bz = b.unbind(-1)
    return torch.stack(
        (
            aw * bw - ax * bx - ay * by - az * bz,
            aw * bx + ax * bw + ay * bz - az * by,
            aw * by - ax * bz + ay * bw + az * bx,
            aw * bz + ax * by - ay * bx + az * bw,
        ),
        dim=-1,
    )


def quat_conj(q: Tensor) -> Tensor:
    return torch.cat((q[..., :1], -q[..., 1:]), dim=-1)


def quat_rotate(q: Tensor, v: Tensor) -> Tensor:
    """``v`` (a vector in the frame ``q`` rotates from) in the outer frame."""
    w, xyz = q[..., :1], q[..., 1:]
    t = 2.0 * torch.linalg.cross(xyz, v, dim=-1)
    return v + w * t + torch.linalg.cross(xyz, t, dim=-1)


def quat_from_axis_angle(axis: Tensor, angle: Tensor) -> Tensor:
    half = 0.5 * angle.unsqueeze(-1)
    return torch.cat((torch.cos(half), axis * torch.sin(half)), dim=-1)


def random_quat(n: int, generator: torch.Generator, device: Any) -> Tensor:
    """Uniform random rotations (Shoemake)."""
    u = torch.rand((n, 3), generator=generator, device=device)
    r1, r2 = torch.sqrt(1 - u[:, 0]), torch.sqrt(u[:, 0])
    t1, t2 = 2 * math.pi * u[:, 1], 2 * math.pi * u[:, 2]
    return torch.stack((r2 * torch.cos(t2), r1 * torch.sin(t1), r1 * torch.cos(t1), r2 * torch.sin(t2)), dim=-1)


def rot6d(q: Tensor) -> Tensor:
    """The first two columns of the rotation matrix: a continuous orientation code (no sign ambiguity)."""
    e1 = torch.zeros_like(q[..., 1:])
    e1[..., 0] = 1.0
    e2 = torch.zeros_like(e1)
    e2[..., 1] = 1.0
    return torch.cat((quat_rotate(q, e1), quat_rotate(q, e2)), dim=-1)


def rotation_angle(a: Tensor, b: Tensor) -> Tensor:
    """The angle (rad) of the rotation taking orientation ``b`` to ``a``."""
    d = quat_mul(a, quat_conj(b))
    return 2.0 * torch.atan2(torch.linalg.norm(d[..., 1:], dim=-1), d[..., 0].abs())


def where_rows(mask: Tensor, new: Tensor, old: Tensor) -> Tensor:
    """Rows of ``new`` where ``mask`` (one bool per world), else ``old``: a reset without a host sync."""
    shape = (mask.shape[0],) + (1,) * (old.dim() - 1)
    return torch.where(mask.view(shape), new, old)


def solid_inertia(kind: str, half: Tensor, mass: Tensor) -> Tensor:
    """Principal inertia [n, 3] of a uniform box, cylinder (axis z) or sphere with MuJoCo's half-sizes."""
    if kind == "box":
        sq = half**2
        return (
            mass.unsqueeze(-1) / 3.0 * torch.stack((sq[:, 1] + sq[:, 2], sq[:, 0] + sq[:, 2], sq[:, 0] + sq[:, 1]), -1)
        )
    if kind == "cylinder":
        r2, h2 = half[:, 0] ** 2, half[:, 1] ** 2
        side = mass * (3.0 * r2 + 4.0 * h2) / 12.0
        return torch.stack((side, side, 0.5 * mass * r2), -1)
    r2 = half[:, 0] ** 2
    return (0.4 * mass * r2).unsqueeze(-1).expand(-1, 3)


def shape_extent(kind: str, half: Tensor) -> tuple[Tensor, Tensor]:
    """(bounding-sphere radius [n], bounding-box half-sizes [n, 3]) of a shape, as MuJoCo's broadphase keeps them."""
    if kind == "box":
        return torch.linalg.norm(half, dim=-1), half
    if kind == "cylinder":
        r, h = half[:, 0], half[:, 1]
        return torch.sqrt(r**2 + h**2), torch.stack((r, r, h), -1)
    r = half[:, 0]
    return r, r.unsqueeze(-1).expand(-1, 3)


def resize_object(env: Any, mask: Tensor, shape: Any, scale: Tensor, mass: Tensor) -> None:
    """Give the object ``shape`` (a ``Shape``) of the masked worlds the size ``scale`` x nominal and ``mass`` (kg):
    its geom size and broadphase bounds, its body's mass, inertia and inverse weights all follow."""
    geom, body = env.geom_id(shape.name), env.bodies[shape.name]
    nominal = torch.tensor(shape.size, dtype=torch.float32, device=env.device)
    half = nominal.unsqueeze(0) * scale.unsqueeze(-1)
    rbound, box = shape_extent(shape.kind, half)
    inertia = solid_inertia(shape.kind, half, mass)
    env.set_model(mask, "geom_size", geom, half)
    env.set_model(mask, "geom_rbound", geom, rbound)
    env.set_model(mask, "geom_aabb", (geom, 1), box)
    env.set_model(mask, "body_mass", body, mass)
    env.set_model(mask, "body_inertia", body, inertia)
    weight = torch.stack((1.0 / mass, 3.0 / inertia.sum(-1)), -1)
    env.set_model(mask, "body_invweight0", body, weight)
