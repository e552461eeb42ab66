"""What each joint of a robot carries at a pose, from the IR's inertials alone: the gravity torque (force for a
sliding joint) it must hold, the inertia about its axis that its servo moves (the mass matrix's diagonal), and the
diagonal of the inverse mass matrix (each joint's mobility with the others free). Each is one or two passes over
the tree, linear in the number of links (a 10,000-link chain is no harder than its length).

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
PIVOT_FLOOR = 1e-12  # kg m^2 (kg): the least articulated inertia of a joint that moves nothing with mass


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


def _tree(robot: Robot) -> tuple[dict[str, list[Joint]], list[Joint]]:
    """Each link's child joints, and the joints in an order where a joint comes after its parent link's joint."""
    children: dict[str, list[Joint]] = {}
    for joint in robot.joints:
        children.setdefault(joint.parent, []).append(joint)
    order, stack = [], [robot.root]
    while stack:
        for joint in children.get(stack.pop(), []):
            order.append(joint)
            stack.append(joint.child)
    return children, order


def link_frames(robot: Robot, pose: dict[str, float]) -> dict[str, np.ndarray]:
    """Every link's 4x4 frame in the root's, with the joints at ``pose`` (0 where it names none)."""
    frames = {robot.root: np.eye(4)}
    for joint in _tree(robot)[1]:
        motion = np.eye(4)
        q = float(pose.get(joint.name, 0.0))
        if joint.type in ("revolute", "continuous"):
            motion[:3, :3] = _rotation(_unit(joint.axis), q)
        elif joint.type == "prismatic":
            motion[:3, 3] = _unit(joint.axis) * q
        frames[joint.child] = exact.matmul(exact.matmul(frames[joint.parent], pose_matrix(joint.origin)), motion)
    return frames


def _tensor(inertial: Inertial) -> np.ndarray:
    ixx, ixy, ixz, iyy, iyz, izz = inertial.inertia
    return np.array([[ixx, ixy, ixz], [ixy, iyy, iyz], [ixz, iyz, izz]], dtype=float)


def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.array([a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]])


def _dot(a: np.ndarray, b: np.ndarray) -> float:
    return math.fsum(float(x) * float(y) for x, y in zip(a, b))


def _skew(v: np.ndarray) -> np.ndarray:
    """[v x]: the matrix of the cross product with ``v``."""
    return np.array([[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]])


@dataclass(frozen=True)
class _Masses:
    """Mass moments about a point, world axes: of one link or of a subtree (sums, so composite bodies add)."""

    mass: float
    first: np.ndarray  # sum of m (c - p), c each centre of mass
    second: np.ndarray  # sum of m (c - p)(c - p)^T
    spin: np.ndarray  # sum of the tensors about their own centres

    def shifted(self, d: np.ndarray) -> _Masses:
        """The same moments about the point p - ``d`` (c - p + d)."""
        first = self.first + self.mass * d
        cross = np.outer(self.first, d)
        second = self.second + cross + cross.T + self.mass * np.outer(d, d)
        return _Masses(self.mass, first, second, self.spin)

    def __add__(self, other: _Masses) -> _Masses:
        return _Masses(
            self.mass + other.mass, self.first + other.first, self.second + other.second, self.spin + other.spin
        )

    def spatial(self) -> np.ndarray:
        """The 6x6 spatial inertia about the point (angular rows and columns first)."""
        rotational = self.spin + (math.fsum(np.diag(self.second).tolist()) * np.eye(3) - self.second)
        coupling = _skew(self.first)
        return np.block([[rotational, coupling], [coupling.T, self.mass * np.eye(3)]])


def _link_masses(inertial: Inertial | None, frame: np.ndarray) -> _Masses:
    """One link's moments about its frame's origin (nothing where it has no inertial or no mass)."""
    if inertial is None or inertial.mass <= 0:
        return _Masses(0.0, np.zeros(3), np.zeros((3, 3)), np.zeros((3, 3)))
    rotation = frame[:3, :3]
    arm = exact.matmul(rotation, np.array(inertial.com, dtype=float).reshape(3, 1)).reshape(3)
    spin = exact.matmul(exact.matmul(rotation, _tensor(inertial)), rotation.T)
    return _Masses(inertial.mass, inertial.mass * arm, inertial.mass * np.outer(arm, arm), spin)


def _subtrees(robot: Robot, frames: dict[str, np.ndarray], masses: dict[str, Inertial]) -> dict[str, _Masses]:
    """Each joint's child link's subtree's moments about that link's origin: one pass from the leaves, each link's
    moments added once to its parent's, shifted (the composite-body pass: linear in the number of links)."""
    children, order = _tree(robot)
    found: dict[str, _Masses] = {}
    for joint in reversed(order):  # a link's child joints come later in ``order``: theirs are done
        link = joint.child
        total = _link_masses(masses.get(link), frames[link])
        for below in children.get(link, []):
            total = total + found[below.child].shifted(frames[below.child][:3, 3] - frames[link][:3, 3])
        found[link] = total
    return found


def _world_axis(joint: Joint, frame: np.ndarray) -> np.ndarray:
    return exact.matmul(frame[:3, :3], _unit(joint.axis).reshape(3, 1)).reshape(3)


def joint_loads(robot: Robot, pose: dict[str, float], masses: dict[str, Inertial]) -> dict[str, Load]:
    """The load of every movable joint at ``pose``; ``masses``: each link's inertial (links without one carry
    nothing; an inertial whose tensor is not valid should be given with its tensor zeroed: only its mass counts).

    The joint's gravity load is the moment of its subtree's weight about its axis, from the subtree's mass and first
    moment about the joint's origin; its inertia, the subtree's second moment about the axis plus the links' own
    tensors (``_subtrees``: one pass over the tree, not one over the subtree for each joint)."""
    frames = link_frames(robot, pose)
    subtrees = _subtrees(robot, frames, masses)
    down = np.array([0.0, 0.0, -GRAVITY])
    loads = {}
    for joint in robot.joints:
        if not joint.movable:
            continue
        axis = _world_axis(joint, frames[joint.child])
        moments = subtrees[joint.child]
        if joint.type == "prismatic":
            loads[joint.name] = Load(_dot(axis, down * moments.mass), moments.mass)
            continue
        gravity = _dot(axis, _cross(moments.first, down))
        about = moments.spin + (math.fsum(np.diag(moments.second).tolist()) * np.eye(3) - moments.second)
        loads[joint.name] = Load(gravity, _dot(axis, exact.matmul(about, axis.reshape(3, 1)).reshape(3)))
    return loads


def _force_shift(d: np.ndarray) -> np.ndarray:
    """The 6x6 map of a spatial force (moment first) about a point to the point ``d`` behind it (p - d)."""
    return np.block([[np.eye(3), _skew(d)], [np.zeros((3, 3)), np.eye(3)]])


def _motion(joint: Joint, frame: np.ndarray) -> np.ndarray:
    """The joint's motion subspace at its origin, world axes (angular part first)."""
    axis = _world_axis(joint, frame)
    return np.concatenate([np.zeros(3), axis]) if joint.type == "prismatic" else np.concatenate([axis, np.zeros(3)])


def _articulated(
    robot: Robot, frames: dict[str, np.ndarray], masses: dict[str, Inertial]
) -> dict[str, tuple[np.ndarray, float]]:
    """The articulated-body pass from the leaves: each movable joint's U = I^A s and D = s^T I^A s (D at least
    PIVOT_FLOOR), I^A the articulated inertia of its child's subtree about the child's origin."""
    children, order = _tree(robot)
    inertia: dict[str, np.ndarray] = {}
    found: dict[str, tuple[np.ndarray, float]] = {}
    for joint in reversed(order):
        link = joint.child
        total = _link_masses(masses.get(link), frames[link]).spatial()
        for below in children.get(link, []):
            shift = _force_shift(frames[below.child][:3, 3] - frames[link][:3, 3])
            carried = inertia.pop(below.child)
            if below.movable:
                u, d = found[below.name]
                carried = carried - np.outer(u, u) / d
            total = total + exact.matmul(exact.matmul(shift, carried), shift.T)
        inertia[link] = total
        if joint.movable:
            s = _motion(joint, frames[link])
            u = exact.matmul(total, s.reshape(6, 1)).reshape(6)
            found[joint.name] = (u, max(_dot(s, u), PIVOT_FLOOR))
    return found


def mobilities(robot: Robot, pose: dict[str, float], masses: dict[str, Inertial]) -> dict[str, float]:
    """The diagonal of the inverse joint-space mass matrix at ``pose``, by movable joint: a joint's acceleration
    under a unit torque (force) of its own with every other joint free. Linear in the number of links: D^-1 of the
    articulated-body pass plus what the compliance Omega of the parent body adds (Omega_child = P^T X^T Omega X P +
    s D^-1 s^T outwards from the fixed root, P = 1 - U D^-1 s^T), in place of inverting the n x n matrix."""
    frames = link_frames(robot, pose)
    pivots = _articulated(robot, frames, masses)
    compliance = {robot.root: np.zeros((6, 6))}
    found = {}
    for joint in _tree(robot)[1]:
        shift = _force_shift(frames[joint.child][:3, 3] - frames[joint.parent][:3, 3])
        seen = exact.matmul(exact.matmul(shift.T, compliance[joint.parent]), shift)  # at the child's origin
        if not joint.movable:
            compliance[joint.child] = seen
            continue
        u, d = pivots[joint.name]
        s = _motion(joint, frames[joint.child])
        found[joint.name] = 1.0 / d + _dot(u, exact.matmul(seen, u.reshape(6, 1)).reshape(6)) / (d * d)
        project = np.eye(6) - np.outer(u, s) / d
        compliance[joint.child] = exact.matmul(exact.matmul(project.T, seen), project) + np.outer(s, s) / d
    return {j.name: found[j.name] for j in robot.joints if j.name in found}
