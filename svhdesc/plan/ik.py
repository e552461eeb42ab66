"""Inverse kinematics for ``--pose`` targets: the group's tip link (the SRDF chain's tip_link, tool0 for
``manipulator``) to a pose in the URDF's root frame, with pinocchio (damped least squares on the frame
Jacobian), from the start state first, then from seeded random states; a solution must be collision-free.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np

from svhdesc.errors import SvhdescError
from svhdesc.extras import require
from svhdesc.model import get
from svhdesc.plan.config import MoveItConfig
from svhdesc.plan.scene import CollisionScene


def pose_matrix(pose: Sequence[float]) -> np.ndarray:
    """4x4 transform of X Y Z ROLL PITCH YAW (fixed axes x, y, z: URDF's rpy)."""
    x, y, z, roll, pitch, yaw = pose
    cr, sr, cp, sp, cy, sy = np.cos(roll), np.sin(roll), np.cos(pitch), np.sin(pitch), np.cos(yaw), np.sin(yaw)
    rotation = np.array(
        [
            [cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
            [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
            [-sp, cp * sr, cp * cr],
        ]
    )
    matrix = np.eye(4)
    matrix[:3, :3], matrix[:3, 3] = rotation, (x, y, z)
    return matrix


class Kinematics:
    def __init__(self, variant: str, config: MoveItConfig) -> None:
        self.pin = require("pinocchio", "planning to a pose (--pose)", "engines")
        self.model = self.pin.buildModelFromUrdf(str(get(variant).urdf_path))
        self.data = self.model.createData()
        self.config = config

    def _q(self, values: Mapping[str, float]) -> np.ndarray:
        q = self.pin.neutral(self.model)
        for name, value in values.items():
            if self.model.existJointName(name):
                q[self.model.joints[self.model.getJointId(name)].idx_q] = value
        return q

    def tip_pose(self, group: str, values: Mapping[str, float]) -> np.ndarray:
        tip = self.config.tips[group]
        frame = self.model.getFrameId(tip)
        self.pin.framesForwardKinematics(self.model, self.data, self._q(values))
        return self.data.oMf[frame].homogeneous.copy()

    def solve(
        self,
        group: str,
        pose: Sequence[float],
        rest: Mapping[str, float],
        start: Sequence[float],
        scene: CollisionScene,
        attempts: int = 40,
        tolerance: float = 1e-5,
    ) -> list[float]:
        pin = self.pin
        if group not in self.config.tips or group not in self.config.ik_groups:
            raise SvhdescError(
                f"group '{group}' has no kinematics solver in kinematics.yaml: --pose needs a chain group"
            )
        joints = self.config.active(group)
        frame = self.model.getFrameId(self.config.tips[group])
        columns = [self.model.joints[self.model.getJointId(j)].idx_v for j in joints]
        rows = [self.model.joints[self.model.getJointId(j)].idx_q for j in joints]
        lower = np.array([self.config.lower[j] for j in joints])
        upper = np.array([self.config.upper[j] for j in joints])
        target = pin.SE3(pose_matrix(pose))
        base = self._q(rest)
        index = scene.joint_index(joints)
        scene.set_state(rest)
        rng = np.random.default_rng(0)
        found: list[np.ndarray] = []
        origin = np.array(start, dtype=float)
        for attempt in range(attempts):
            # The start first, then random states nearer and nearer to anywhere in the limits.
            spread = min(1.0, 0.15 * attempt)
            guess = np.clip(origin + spread * rng.uniform(lower - origin, upper - origin), lower, upper)
            if attempt == 0:
                guess = origin.copy()
            q = base.copy()
            for _ in range(500):
                q[rows] = guess
                pin.framesForwardKinematics(self.model, self.data, q)
                error = pin.log6(self.data.oMf[frame].actInv(target)).vector
                if np.linalg.norm(error) < tolerance:
                    break
                jacobian = pin.computeFrameJacobian(self.model, self.data, q, frame, pin.ReferenceFrame.LOCAL)
                j = jacobian[:, columns]
                step = j.T @ np.linalg.solve(j @ j.T + 1e-4 * np.eye(6), error)
                step *= min(1.0, 0.3 / max(np.abs(step).max(), 1e-12))  # small steps: stay in one IK branch
                guess = np.clip(guess + step, lower, upper)
            else:
                continue
            if scene.valid(index, guess):
                found.append(guess.copy())
                if len(found) >= 3 or attempt == 0:
                    break
        if found:
            return min(found, key=lambda g: float(np.abs(g - origin).sum())).tolist()
        x, y, z = pose[:3]
        raise SvhdescError(f"no collision-free IK solution for {self.config.tips[group]} at ({x}, {y}, {z}) ...")
