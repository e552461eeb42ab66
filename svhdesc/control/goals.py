"""Goal checks of ros_control's JointTrajectoryController, on plain values (no ROS needed).

Error codes are control_msgs/FollowJointTrajectoryResult's, case by case as noetic's
joint_trajectory_controller_impl.h (goalCB) and init_joint_trajectory.h give them: joints that do not
map onto the controller's -> INVALID_JOINTS; anything that makes initJointTrajectory return an empty
trajectory (times not strictly increasing, sizes that differ, every point at or before the next
update) -> INVALID_GOAL. The controller never returns OLD_HEADER_TIMESTAMP.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from enum import IntEnum
from typing import Any

from svhdesc.control.spline import Point, validate_points


class ErrorCode(IntEnum):
    """FollowJointTrajectory's result codes. control_msgs' ROS 1 (1.5) and ROS 2 (4.x, Jazzy) actions give
    every code the same value, so one enum serves both adapters."""

    SUCCESSFUL = 0
    INVALID_GOAL = -1
    INVALID_JOINTS = -2
    OLD_HEADER_TIMESTAMP = -3
    PATH_TOLERANCE_VIOLATED = -4
    GOAL_TOLERANCE_VIOLATED = -5


SUCCESSFUL = ErrorCode.SUCCESSFUL
INVALID_GOAL = ErrorCode.INVALID_GOAL
INVALID_JOINTS = ErrorCode.INVALID_JOINTS
OLD_HEADER_TIMESTAMP = ErrorCode.OLD_HEADER_TIMESTAMP
PATH_TOLERANCE_VIOLATED = ErrorCode.PATH_TOLERANCE_VIOLATED
GOAL_TOLERANCE_VIOLATED = ErrorCode.GOAL_TOLERANCE_VIOLATED


@dataclass(frozen=True)
class Rejection:
    code: ErrorCode
    reason: str


def points_of(messages: Iterable[Any], seconds: Callable[[Any], float]) -> list[Point]:
    """JointTrajectoryPoint messages (ROS 1's and ROS 2's have the same fields) as the core's Points; ``seconds``
    reads the transport's Duration."""
    return [
        Point(
            seconds(point.time_from_start),
            tuple(point.positions),
            tuple(point.velocities) or None,
            tuple(point.accelerations) or None,
        )
        for point in messages
    ]


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
    if not names:
        return Rejection(INVALID_JOINTS, "the goal names no joints")
    unknown = [n for n in names if n not in controller_joints]
    if unknown:
        return Rejection(INVALID_JOINTS, f"joints {unknown} are not controlled here ({list(controller_joints)})")
    if not allow_partial and set(names) != set(controller_joints):
        missing = [n for n in controller_joints if n not in names]
        return Rejection(INVALID_JOINTS, f"the goal must name every joint; missing {missing}")
    problem = validate_points(points, len(names))
    if problem:
        return Rejection(INVALID_GOAL, problem)
    if not math.isfinite(stamp):
        return Rejection(INVALID_GOAL, f"header stamp {stamp} is not finite")
    start = now if stamp == 0.0 else stamp
    if start + points[-1].time <= now:
        # init_joint_trajectory.h: the trajectory comes back empty and goalCB rejects with INVALID_GOAL.
        return Rejection(
            INVALID_GOAL,
            f"Dropping all {len(points)} trajectory point(s), as they occur before the current time. "
            f"Last point is {now - (start + points[-1].time):.3f}s in the past.",
        )
    for i, point in enumerate(points):  # not checked by the controller: see README (deviations)
        for name, value in zip(names, point.positions):
            low, high = limits[name]
            if not low - 1e-9 <= value <= high + 1e-9:
                return Rejection(INVALID_GOAL, f"point {i}: {name} = {value} is outside its limits [{low}, {high}]")
    return None


@dataclass
class Tolerances:
    """Per-joint tolerances (0: unchecked), as JointTrajectoryController's ``constraints``
    (tolerances.h): path and goal position, goal velocity (``stopped_velocity_tolerance``), path
    velocity (only from goals), and the time allowed after the end to get within the goal."""

    path: dict[str, float]
    goal: dict[str, float]
    stopped_velocity: float
    goal_time: float
    goal_velocity: dict[str, float] = field(default_factory=dict)
    path_velocity: dict[str, float] = field(default_factory=dict)

    def __post_init__(self) -> None:
        for joint in self.goal:
            self.goal_velocity.setdefault(joint, self.stopped_velocity)
        for joint in self.path:
            self.path_velocity.setdefault(joint, 0.0)

    def merged(
        self,
        path: Mapping[str, float],
        goal: Mapping[str, float],
        goal_time: float,
        path_velocity: Mapping[str, float] | None = None,
        goal_velocity: Mapping[str, float] | None = None,
    ) -> Tolerances:
        """Goal-given tolerances over the defaults: 0 keeps the default, negative lifts the limit."""

        def merge(default: dict[str, float], given: Mapping[str, float] | None) -> dict[str, float]:
            out = dict(default)
            for name, value in (given or {}).items():
                if name in out and value != 0.0:
                    out[name] = 0.0 if value < 0 else value
            return out

        if goal_time < 0:
            time = 0.0
        elif goal_time > 0:
            time = goal_time
        else:
            time = self.goal_time
        return Tolerances(
            merge(self.path, path),
            merge(self.goal, goal),
            self.stopped_velocity,
            time,
            merge(self.goal_velocity, goal_velocity),
            merge(self.path_velocity, path_velocity),
        )
