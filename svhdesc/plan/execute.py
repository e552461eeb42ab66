"""Execute a plan as MoveIt's simple controller manager does: one FollowJointTrajectory goal per controller that
moveit_controllers.yaml names for the plan's joints, sent together; the tracking error is read from each
controller's state topic while they run.

This module decides (which controllers, whether the robot is at the plan's start, each goal's points, the verdict);
a ``Transport`` sends the goals and reads the robot: ROS 1 (``svhdesc.plan.ros1``, to ``svhdesc sim --ros``) or
ROS 2 (``svhdesc.plan.ros2``, to ``svhdesc sim --ros2``). Joint names here are the plan's (the URDF's).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Protocol

from svhdesc.errors import SvhdescError
from svhdesc.plan.config import Controller
from svhdesc.plan.planner import Plan

START_TOLERANCE = 0.01  # rad: MoveIt refuses to execute when the robot is elsewhere (allowed_start_tolerance)


@dataclass
class Execution:
    success: bool
    results: dict[str, tuple[int, str]]  # controller -> (error_code, error_string)
    max_tracking_error: float  # rad, over the execution, every joint
    final_error: float  # rad, desired end vs where the joints are after the goal ends

    def as_json(self) -> dict:
        return {
            "success": self.success,
            "results": {k: {"error_code": c, "error_string": s} for k, (c, s) in self.results.items()},
            "max_tracking_error": self.max_tracking_error,
            "final_error": self.final_error,
        }


@dataclass(frozen=True)
class ControllerGoal:
    """One controller's FollowJointTrajectory goal: its joints of the plan and every timed point."""

    controller: Controller
    joints: tuple[str, ...]
    times: tuple[float, ...]
    positions: tuple[tuple[float, ...], ...]
    velocities: tuple[tuple[float, ...], ...]
    accelerations: tuple[tuple[float, ...], ...]


class Transport(Protocol):
    def positions(self) -> dict[str, float]:
        """Where the joints are now (/joint_states), by the plan's joint names."""
        ...

    def follow(self, goals: Sequence[ControllerGoal], wait: float) -> tuple[dict[str, tuple[int, str]], float]:
        """Send every goal at once and wait up to ``wait`` s for each result: each controller's (error_code,
        error_string) and the largest position error its state topic reported meanwhile (rad)."""
        ...


def execute(plan: Plan, controllers: Sequence[Controller], transport: Transport, timeout: float = 120.0) -> Execution:
    if not plan.success:
        raise SvhdescError("nothing to execute: the plan failed")
    chosen = [c for c in controllers if set(c.joints) & set(plan.joint_names)]
    uncovered = set(plan.joint_names) - {j for c in chosen for j in c.joints}
    if uncovered:
        raise SvhdescError(f"no controller in moveit_controllers.yaml drives {sorted(uncovered)}")
    here = transport.positions()
    off = {j: abs(here[j] - p) for j, p in zip(plan.joint_names, plan.positions[0])}
    worst = max(off, key=off.get)
    if off[worst] > START_TOLERANCE:
        raise SvhdescError(f"the robot is not at the plan's start: {worst} is {off[worst]:.4f} rad away")
    results, tracking = transport.follow([goal_for(plan, c) for c in chosen], plan.duration + timeout)
    there = transport.positions()
    final = max(abs(there[j] - p) for j, p in zip(plan.joint_names, plan.positions[-1]))
    return Execution(all(code == 0 for code, _ in results.values()), results, tracking, final)


def goal_for(plan: Plan, controller: Controller) -> ControllerGoal:
    """The plan's points for the joints ``controller`` drives, in the controller's joint order."""
    columns = [plan.joint_names.index(j) for j in controller.joints if j in plan.joint_names]

    def pick(rows: Sequence[Sequence[float]]) -> tuple[tuple[float, ...], ...]:
        return tuple(tuple(float(row[c]) for c in columns) for row in rows)

    return ControllerGoal(
        controller,
        tuple(plan.joint_names[c] for c in columns),
        tuple(float(t) for t in plan.times),
        pick(plan.positions),
        pick(plan.velocities),
        pick(plan.accelerations),
    )
