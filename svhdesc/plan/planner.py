"""Joint-space planning with OMPL (RRTConnect by default, as MoveIt's OMPL pipeline), path simplification,
and time parameterization within joint_limits.yaml's limits (scaled by its default factors, as MoveIt does).

Time parameterization: Ruckig, rest to rest between the simplified waypoints with phase synchronization,
so every joint moves on the straight joint-space segment the planner checked, within the velocity and
acceleration limits.
"""

from __future__ import annotations

import math
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from svhdesc.errors import SvhdescError
from svhdesc.extras import require
from svhdesc.plan.config import MoveItConfig
from svhdesc.plan.scene import CollisionScene

PLANNERS = ("RRTConnect", "RRT", "RRTstar", "PRM", "PRMstar", "KPIECE1", "BKPIECE1", "LBKPIECE1", "BITstar")
# rad: the longest joint-space step between two collision checks along a motion. At 0.01 a path grazed the wall of
# tests/plan/test_plan.py between two checks (found by a check every 5 mrad, in one test order of a fresh clone's
# run: OMPL's sampling depends on the plans its process made before); 0.0025 checks each segment at least twice as
# densely as that.
CHECK_STEP = 0.0025


@dataclass
class Plan:
    success: bool
    group: str
    planner: str
    planning_time: float
    joint_names: list[str]
    waypoints: list[list[float]] = field(default_factory=list)  # the simplified, checked path
    times: list[float] = field(default_factory=list)
    positions: list[list[float]] = field(default_factory=list)
    velocities: list[list[float]] = field(default_factory=list)
    accelerations: list[list[float]] = field(default_factory=list)
    message: str = ""

    @property
    def duration(self) -> float:
        return self.times[-1] if self.times else 0.0

    @property
    def path_length(self) -> float:
        """Joint-space length of the simplified path (rad)."""
        w = np.asarray(self.waypoints)
        return float(np.linalg.norm(np.diff(w, axis=0), axis=1).sum()) if len(w) > 1 else 0.0

    def as_json(self) -> dict:
        return {
            "success": self.success,
            "group": self.group,
            "planner": self.planner,
            "planning_time": self.planning_time,
            "path_length": self.path_length,
            "duration": self.duration,
            "joint_names": self.joint_names,
            "waypoints": self.waypoints,
            "points": [
                {"time_from_start": t, "positions": p, "velocities": v, "accelerations": a}
                for t, p, v, a in zip(self.times, self.positions, self.velocities, self.accelerations)
            ],
            "message": self.message,
        }


def _ompl_silence() -> None:
    from ompl import util

    util.setLogLevel(util.LogLevel.LOG_WARN)


def seed_ompl(seed: int) -> None:
    """Seed OMPL's sampling once per process, before the first plan (OMPL ignores later seeds)."""
    from ompl import util

    _ompl_silence()
    util.RNG.setSeed(max(1, seed))


def plan_motion(
    scene: CollisionScene,
    config: MoveItConfig,
    group: str,
    rest: Mapping[str, float],
    start: Sequence[float],
    goal: Sequence[float],
    planner: str = "RRTConnect",
    timeout: float = 5.0,
    velocity_scaling: float | None = None,
    acceleration_scaling: float | None = None,
) -> Plan:
    """Plan ``group`` from ``start`` to ``goal`` (its active joints' values) with everything else at ``rest``."""
    require("ompl", "planning", "plan")
    _ompl_silence()
    if planner not in PLANNERS:
        raise SvhdescError(f"unknown planner '{planner}'; choose from {', '.join(PLANNERS)}")
    joints = config.active(group)
    _check_ends(config, group, joints, start, goal)
    scene.set_state(rest)
    index = scene.joint_index(joints)
    collision = _ends_in_collision(scene, index, start, goal)
    if collision is not None:
        return Plan(False, group, planner, 0.0, joints, message=collision)
    setup, information = _ompl_setup(scene, config, joints, index, start, goal, planner)
    began = time.perf_counter()
    solved = setup.solve(timeout)
    exact = bool(solved) and str(solved) == "Exact solution"
    if exact and setup.getSolutionPath().getStateCount() > 2:
        _simplify(information, setup.getSolutionPath())
    elapsed = time.perf_counter() - began
    if not exact:
        return Plan(False, group, planner, elapsed, joints, message=f"no path found in {timeout} s ({solved})")
    n = len(joints)
    path = setup.getSolutionPath()
    waypoints = [list(path.getState(i)[0:n]) for i in range(path.getStateCount())]
    waypoints[0], waypoints[-1] = list(map(float, start)), list(map(float, goal))
    result = Plan(True, group, planner, elapsed, joints, waypoints)
    time_parameterize(result, config, velocity_scaling, acceleration_scaling)
    return result


def _check_ends(
    config: MoveItConfig, group: str, joints: list[str], start: Sequence[float], goal: Sequence[float]
) -> None:
    """Start and goal have one value per joint of the group, each within the joint's limits."""
    n = len(joints)
    for label, values in (("start", start), ("goal", goal)):
        if len(values) != n:
            raise SvhdescError(f"{label} has {len(values)} values for the {n} joints of '{group}'")
        for joint, value in zip(joints, values):
            if not config.lower[joint] - 1e-9 <= value <= config.upper[joint] + 1e-9:
                raise SvhdescError(
                    f"{label}: {joint} = {value} is outside [{config.lower[joint]}, {config.upper[joint]}]"
                )


def _ends_in_collision(
    scene: CollisionScene, index: np.ndarray, start: Sequence[float], goal: Sequence[float]
) -> str | None:
    """Why the start or the goal state is in collision (the first pair), or None."""
    for label, values in (("start", start), ("goal", goal)):
        pairs = scene.colliding_pairs(index, values)
        if pairs:
            a, b, depth = pairs[0]
            return f"{label} state in collision: {a}-{b} {depth:.4f} m"
    return None


def _ompl_setup(
    scene: CollisionScene,
    config: MoveItConfig,
    joints: list[str],
    index: np.ndarray,
    start: Sequence[float],
    goal: Sequence[float],
    planner: str,
) -> tuple[Any, Any]:
    """OMPL's SimpleSetup over the joints' bounds with the scene as validity checker; and its space information."""
    from ompl import base as ob
    from ompl import geometric as og

    n = len(joints)
    space = ob.RealVectorStateSpace(n)
    bounds = ob.RealVectorBounds(n)
    for i, joint in enumerate(joints):
        bounds.setLow(i, config.lower[joint])
        bounds.setHigh(i, config.upper[joint])
    space.setBounds(bounds)
    setup = og.SimpleSetup(space)
    setup.setStateValidityChecker(lambda state: scene.valid(index, state[0:n]))
    information = setup.getSpaceInformation()
    information.setStateValidityCheckingResolution(CHECK_STEP / space.getMaximumExtent())
    first, last = space.allocState(), space.allocState()
    first[0:n] = list(map(float, start))
    last[0:n] = list(map(float, goal))
    setup.setStartAndGoalStates(first, last)
    setup.setPlanner(getattr(og, planner)(information))
    return setup, information


def _simplify(information: Any, path: Any) -> None:
    """Vertex reduction and shortcutting (no B-spline smoothing: it would add vertices, and each
    vertex is a stop for the rest-to-rest time parameterization)."""
    from ompl import geometric as og

    simplifier = og.PathSimplifier(information)
    simplifier.reduceVertices(path)
    simplifier.partialShortcutPath(path)
    simplifier.reduceVertices(path)


def time_parameterize(
    plan: Plan, config: MoveItConfig, velocity_scaling: float | None = None, acceleration_scaling: float | None = None
) -> None:
    """Fill ``plan``'s timed points: rest-to-rest Ruckig segments, sampled every 0.05 s."""
    ruckig = require("ruckig", "time parameterization", "plan")
    joints = plan.joint_names
    n = len(joints)
    vs = config.velocity_scaling if velocity_scaling is None else velocity_scaling
    acs = config.acceleration_scaling if acceleration_scaling is None else acceleration_scaling
    if not (0 < vs <= 1 and 0 < acs <= 1):
        raise SvhdescError(f"scaling factors must lie in (0, 1], got {vs}, {acs}")
    vmax = [config.max_velocity.get(j, 1.0) * vs for j in joints]
    amax = [config.max_acceleration.get(j, 1.0) * acs for j in joints]
    generator = ruckig.Ruckig(n)
    times, positions, velocities, accelerations = [0.0], [plan.waypoints[0]], [[0.0] * n], [[0.0] * n]
    offset = 0.0
    for a, b in zip(plan.waypoints, plan.waypoints[1:]):
        request = ruckig.InputParameter(n)
        request.current_position, request.target_position = a, b
        request.current_velocity = request.current_acceleration = [0.0] * n
        request.target_velocity = request.target_acceleration = [0.0] * n
        request.max_velocity, request.max_acceleration = vmax, amax
        request.max_jerk = [math.inf] * n
        request.synchronization = ruckig.Synchronization.Phase
        trajectory = ruckig.Trajectory(n)
        if generator.calculate(request, trajectory) not in (ruckig.Result.Working, ruckig.Result.Finished):
            raise SvhdescError(f"time parameterization failed between {a} and {b}")
        duration = trajectory.duration
        steps = max(1, math.ceil(duration / 0.05))
        for k in range(1, steps + 1):
            t = duration * k / steps
            p, v, acc = trajectory.at_time(t)
            times.append(offset + t)
            positions.append(list(p))
            velocities.append(list(v))
            accelerations.append(list(acc))
        offset += duration
    plan.times, plan.positions, plan.velocities, plan.accelerations = times, positions, velocities, accelerations
