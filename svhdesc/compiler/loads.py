"""What each joint of a robot carries at a pose, from the IR's inertials alone: the gravity torque (force for a
sliding joint) it must hold, the inertia about its axis that its servo moves (the mass matrix's diagonal), and the
joint-space mass matrix itself.

``svhdesc init`` sizes drives with these before anything is built: an unrated joint gets an effort that holds the
robot at ``home``, and no servo is stiffer than the timestep can integrate on the inertia behind it. Scalar and
element-wise arithmetic only (``core.exact``), so the numbers init writes are the same on every CPU.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from svhdesc.core import exact
from svhdesc.core.frames import pose_matrix
from svhdesc.ir import Inertial, Joint, Robot

GRAVITY = 9.81  # m/s^2, along -z of the root link


@dataclass(frozen=True)
class Load:
    gravity: float  # N m (N): the torque (force) gravity puts on the joint at the pose, about (along) its axis
    inertia: float  # kg m^2 (kg): the inertia its drive moves, about (along) its axis, at the pose


def _rotation(axis: np.ndarray, angle: float) -> np.ndarray:
    """Rodrigues' rotation about a unit axis, in scalar arithmetic."""
    x, y, z = (float(v) for v in axis)
    c, s = math.cos(angle), math.sin(angle)
    t = 1.0 - c
    return np.array(
        [
            [t * x * x + c, t * x * y - s * z, t * x * z + s * y],
            [t * x * y + s * z, t * y * y + c, t * y * z - s * x],
            [t * x * z - s * y, t * y * z + s * x, t * z * z + c],
        ]
    )


def _unit(axis: tuple[float, float, float]) -> np.ndarray:
    length = exact.norm(axis)
    return np.array([float(v) / length for v in axis])


def link_frames(robot: Robot, pose: dict[str, float]) -> dict[str, np.ndarray]:
    """Every link's 4x4 frame in the root's, with the joints at ``pose`` (0 where it names none)."""
    frames = {robot.root: np.eye(4)}
    children: dict[str, list[Joint]] = {}
    for joint in robot.joints:
        children.setdefault(joint.parent, []).append(joint)
    stack = [robot.root]
    while stack:
        parent = stack.pop()
        for joint in children.get(parent, []):
            motion = np.eye(4)
            q = float(pose.get(joint.name, 0.0))
            if joint.type in ("revolute", "continuous"):
                motion[:3, :3] = _rotation(_unit(joint.axis), q)
            elif joint.type == "prismatic":
                motion[:3, 3] = _unit(joint.axis) * q
            frames[joint.child] = exact.matmul(exact.matmul(frames[parent], pose_matrix(joint.origin)), motion)
            stack.append(joint.child)
    return frames


def _descendants(robot: Robot, link: str) -> list[str]:
    children: dict[str, list[str]] = {}
    for joint in robot.joints:
        children.setdefault(joint.parent, []).append(joint.child)
    found, stack = [], [link]
    while stack:
        name = stack.pop()
        found.append(name)
        stack.extend(children.get(name, []))
    return found


def _tensor(inertial: Inertial) -> np.ndarray:
    ixx, ixy, ixz, iyy, iyz, izz = inertial.inertia
    return np.array([[ixx, ixy, ixz], [ixy, iyy, iyz], [ixz, iyz, izz]], dtype=float)


def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.array([a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]])


def _dot(a: np.ndarray, b: np.ndarray) -> float:
    return math.fsum(float(x) * float(y) for x, y in zip(a, b))


def joint_loads(robot: Robot, pose: dict[str, float], masses: dict[str, Inertial]) -> dict[str, Load]:
    """The load of every movable joint at ``pose``; ``masses``: each link's inertial (links without one carry
    nothing; an inertial whose tensor is not valid should be given with its tensor zeroed: only its mass counts)."""
    frames = link_frames(robot, pose)
    down = np.array([0.0, 0.0, -GRAVITY])
    loads = {}
    for joint in robot.joints:
        if not joint.movable:
            continue
        frame = frames[joint.child]
        axis = exact.matmul(frame[:3, :3], _unit(joint.axis).reshape(3, 1)).reshape(3)
        origin = frame[:3, 3]
        gravity, inertia = [], []
        for name in _descendants(robot, joint.child):
            inertial = masses.get(name)
            if inertial is None or inertial.mass <= 0:
                continue
            rotation = frames[name][:3, :3]
            centre = frames[name][:3, 3] + exact.matmul(rotation, np.array(inertial.com).reshape(3, 1)).reshape(3)
            weight = down * inertial.mass
            if joint.type == "prismatic":
                gravity.append(_dot(axis, weight))
                inertia.append(inertial.mass)
                continue
            arm = centre - origin
            gravity.append(_dot(axis, _cross(arm, weight)))
            local = exact.matmul(rotation.T, axis.reshape(3, 1)).reshape(3)
            spin = _dot(local, exact.matmul(_tensor(inertial), local.reshape(3, 1)).reshape(3))
            lever = _cross(axis, arm)
            inertia.append(spin + inertial.mass * _dot(lever, lever))
        loads[joint.name] = Load(math.fsum(gravity), math.fsum(inertia))
    return loads


def _columns(robot: Robot, frames: dict[str, np.ndarray]) -> dict[str, tuple[str, np.ndarray, np.ndarray]]:
    """Each movable joint's (type, world axis, world origin)."""
    found = {}
    for joint in robot.joints:
        if joint.movable:
            frame = frames[joint.child]
            axis = exact.matmul(frame[:3, :3], _unit(joint.axis).reshape(3, 1)).reshape(3)
            found[joint.name] = (joint.type, axis, frame[:3, 3])
    return found


def mass_matrix(
    robot: Robot, pose: dict[str, float], masses: dict[str, Inertial]
) -> tuple[list[str], list[list[float]]]:
    """The joint-space mass matrix at ``pose`` over the movable joints (their names, in the robot's order): for each
    link, m Jv^T Jv + Jw^T I Jw with the Jacobian of its centre of mass."""
    frames = link_frames(robot, pose)
    columns = _columns(robot, frames)
    names = list(columns)
    index = {name: i for i, name in enumerate(names)}
    parent_joint = {j.child: j for j in robot.joints}
    matrix = [[0.0] * len(names) for _ in names]
    for link, inertial in masses.items():
        if inertial is None or inertial.mass <= 0 or link not in frames:
            continue
        rotation = frames[link][:3, :3]
        centre = frames[link][:3, 3] + exact.matmul(rotation, np.array(inertial.com).reshape(3, 1)).reshape(3)
        world = exact.matmul(exact.matmul(rotation, _tensor(inertial)), rotation.T)
        chain, name = [], link
        while name in parent_joint:  # the joints that move this link
            joint = parent_joint[name]
            if joint.name in index:
                chain.append(joint.name)
            name = joint.parent
        jacobian = {}
        for joint_name in chain:
            kind, axis, origin = columns[joint_name]
            if kind == "prismatic":
                jacobian[joint_name] = (axis, np.zeros(3))
            else:
                jacobian[joint_name] = (_cross(axis, centre - origin), axis)
        for a in chain:
            for b in chain:
                (va, wa), (vb, wb) = jacobian[a], jacobian[b]
                spin = _dot(wa, exact.matmul(world, wb.reshape(3, 1)).reshape(3))
                matrix[index[a]][index[b]] += inertial.mass * _dot(va, vb) + spin
    return names, matrix


def inverse_diagonal(matrix: list[list[float]], floor: float = 1e-12) -> list[float]:
    """The diagonal of the inverse of a symmetric positive semi-definite matrix, by Gauss-Jordan elimination in
    scalar arithmetic (the same bits on every CPU); a pivot below ``floor`` is raised to it (a joint that moves
    nothing with mass)."""
    n = len(matrix)
    work = [[*row, *(1.0 if i == j else 0.0 for j in range(n))] for i, row in enumerate(matrix)]
    for col in range(n):
        pivot = max(work[col][col], floor)
        work[col][col] = pivot
        for j in range(2 * n):
            work[col][j] = work[col][j] / pivot if j != col else 1.0
        for row in range(n):
            if row != col and work[row][col] != 0.0:
                factor = work[row][col]
                for j in range(2 * n):
                    work[row][j] -= factor * work[col][j]
    return [work[i][n + i] for i in range(n)]
