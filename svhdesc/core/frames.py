"""Rigid transforms shared by the stages and exporters (scalar math, so the bits do not depend on the CPU)."""

from __future__ import annotations

import math

import numpy as np

from svhdesc.core import exact
from svhdesc.ir import Pose


def rpy_matrix(rpy: tuple[float, float, float]) -> np.ndarray:
    """URDF convention: R = Rz(yaw) Ry(pitch) Rx(roll)."""
    r, p, y = rpy
    cr, sr, cp, sp, cy, sy = math.cos(r), math.sin(r), math.cos(p), math.sin(p), math.cos(y), math.sin(y)
    return np.array(
        [
            [cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
            [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
            [-sp, cp * sr, cp * cr],
        ]
    )


def pose_matrix(pose: Pose) -> np.ndarray:
    matrix = np.eye(4)
    matrix[:3, :3] = rpy_matrix(pose.rpy)
    matrix[:3, 3] = pose.xyz
    return matrix


def quat_wxyz(pose: Pose) -> tuple[float, float, float, float]:
    """Unit quaternion (w, x, y, z) of the pose's rotation, computed from rpy directly."""
    r, p, y = (v / 2.0 for v in pose.rpy)
    cr, sr, cp, sp, cy, sy = math.cos(r), math.sin(r), math.cos(p), math.sin(p), math.cos(y), math.sin(y)
    q = (
        cr * cp * cy + sr * sp * sy,
        sr * cp * cy - cr * sp * sy,
        cr * sp * cy + sr * cp * sy,
        cr * cp * sy - sr * sp * cy,
    )
    if q[0] < 0:  # canonical sign keeps outputs deterministic
        q = tuple(-v for v in q)
    return tuple(float(v) for v in q)  # type: ignore[return-value]


def matrix_pose(matrix: np.ndarray) -> Pose:
    """Inverse of ``pose_matrix`` (URDF rpy, yaw-pitch-roll)."""
    rotation = matrix[:3, :3]
    pitch = math.asin(min(max(-float(rotation[2, 0]), -1.0), 1.0))
    if abs(rotation[2, 0]) < 1.0 - 1e-12:
        roll = math.atan2(float(rotation[2, 1]), float(rotation[2, 2]))
        yaw = math.atan2(float(rotation[1, 0]), float(rotation[0, 0]))
    else:  # gimbal lock: put everything in yaw
        roll = 0.0
        yaw = math.atan2(-float(rotation[0, 1]), float(rotation[1, 1]))
    return Pose(tuple(float(v) for v in matrix[:3, 3]), (roll, pitch, yaw))  # type: ignore[arg-type]


def axis_frame(axis: np.ndarray) -> np.ndarray:
    """A rotation whose z column is the unit ``axis`` (x from the coordinate axis least aligned with it)."""
    axis = np.asarray(axis, dtype=float) / exact.norm(axis)
    helper = np.eye(3)[int(np.argmin(np.abs(axis)))]
    u = np.cross(axis, helper)
    u = u / exact.norm(u)
    return np.column_stack([u, np.cross(axis, u), axis])
