"""Goal checks of ros_control's JointTrajectoryController, on plain values (no ROS needed).

Error codes are control_msgs/FollowJointTrajectoryResult's.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

from ..sim.trajectory import Point, validate_points

SUCCESSFUL = 0
INVALID_GOAL = -1
INVALID_JOINTS = -2
OLD_HEADER_TIMESTAMP = -3
PATH_TOLERANCE_VIOLATED = -4
GOAL_TOLERANCE_VIOLATED = -5


@dataclass(frozen=True)
class Rejection:
    code: int
    reason: str


def check_goal(
    joint_names: Sequence[str],
    points: Sequence[Point],
    stamp: float,
    now: float,
    controller_joints: Sequence[str],
    allow_partial: bool,
    limits: Mapping[str, tuple[float, float]],
) -> Rejection | None:
    """Why a trajectory cannot be accepted (None when it can). ``stamp`` 0 means "start now"."""
    names = list(joint_names)
    if not names or len(set(names)) != len(names):
        return Rejection(INVALID_JOINTS, f"joint names are empty or repeat: {names}")
    unknown = [n for n in names if n not in controller_joints]
    if unknown:
        return Rejection(INVALID_JOINTS, f"joints {unknown} are not controlled here ({list(controller_joints)})")
    if not allow_partial and set(names) != set(controller_joints):
        missing = [n for n in controller_joints if n not in names]
        return Rejection(INVALID_JOINTS, f"the goal must name every joint; missing {missing}")
    problem = validate_points(points, len(names))
    if problem:
        return Rejection(INVALID_GOAL, problem)
    for i, point in enumerate(points):
        for name, value in zip(names, point.positions):
            low, high = limits[name]
            if not low - 1e-9 <= value <= high + 1e-9:
                return Rejection(INVALID_GOAL, f"point {i}: {name} = {value} is outside its limits [{low}, {high}]")
    if not math.isfinite(stamp):
        return Rejection(INVALID_GOAL, f"header stamp {stamp} is not finite")
    start = now if stamp == 0.0 else stamp
    if start + points[-1].time < now:
        return Rejection(
            OLD_HEADER_TIMESTAMP,
            f"the trajectory ends at t = {start + points[-1].time:.3f} s, before now ({now:.3f} s)",
        )
    return None


@dataclass
class Tolerances:
    """Per-joint tolerances (0: unchecked), as JointTrajectoryController's ``constraints``."""

    path: dict[str, float]
    goal: dict[str, float]
    stopped_velocity: float
    goal_time: float

    def merged(self, path: Mapping[str, float], goal: Mapping[str, float], goal_time: float) -> Tolerances:
        """Goal-given tolerances over the defaults: 0 keeps the default, -1 lifts the limit."""

        def merge(default: dict[str, float], given: Mapping[str, float]) -> dict[str, float]:
            out = dict(default)
            for name, value in given.items():
                if name in out and value != 0.0:
                    out[name] = 0.0 if value < 0 else value
            return out

        return Tolerances(
            merge(self.path, path),
            merge(self.goal, goal),
            self.stopped_velocity,
            goal_time if goal_time > 0 else self.goal_time,
        )
