"""Joint trajectories sampled the way ros_control's JointTrajectoryController samples them.

Each segment between two points is a polynomial in the time since the segment start, chosen from
what *both* ends carry (joint_trajectory_controller's QuinticSplineSegment):
positions only -> linear, positions + velocities -> cubic (Hermite), + accelerations -> quintic.
Before the first point the trajectory holds its start state; after the last it holds the last
position at rest.
"""

from __future__ import annotations

import bisect
import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Point:
    """One waypoint: ``time`` is seconds from the trajectory start (``time_from_start``)."""

    time: float
    positions: tuple[float, ...]
    velocities: tuple[float, ...] | None = None
    accelerations: tuple[float, ...] | None = None


@dataclass(frozen=True)
class State:
    positions: np.ndarray
    velocities: np.ndarray
    accelerations: np.ndarray


def _coefficients(
    p0: np.ndarray,
    v0: np.ndarray | None,
    a0: np.ndarray | None,
    p1: np.ndarray,
    v1: np.ndarray | None,
    a1: np.ndarray | None,
    duration: float,
) -> np.ndarray:
    """Polynomial coefficients c[k] (power k), shape (6, n joints), of one segment."""
    n = len(p0)
    c = np.zeros((6, n))
    c[0] = p0
    if duration <= 0.0:
        c[0] = p1
        return c
    t = duration
    if v0 is None or v1 is None:
        c[1] = (p1 - p0) / t
    elif a0 is None or a1 is None:
        c[1] = v0
        c[2] = (-3.0 * p0 + 3.0 * p1 - 2.0 * t * v0 - t * v1) / t**2
        c[3] = (2.0 * p0 - 2.0 * p1 + t * v0 + t * v1) / t**3
    else:
        c[1] = v0
        c[2] = 0.5 * a0
        c[3] = (-20.0 * p0 + 20.0 * p1 - 3.0 * a0 * t**2 + a1 * t**2 - 12.0 * v0 * t - 8.0 * v1 * t) / (2.0 * t**3)
        c[4] = (30.0 * p0 - 30.0 * p1 + 3.0 * a0 * t**2 - 2.0 * a1 * t**2 + 16.0 * v0 * t + 14.0 * v1 * t) / (
            2.0 * t**4
        )
        c[5] = (-12.0 * p0 + 12.0 * p1 - a0 * t**2 + a1 * t**2 - 6.0 * v0 * t - 6.0 * v1 * t) / (2.0 * t**5)
    return c


def _array(values: Sequence[float] | None, n: int) -> np.ndarray | None:
    return None if values is None or len(values) == 0 else np.asarray(values, dtype=float).reshape(n)


class Trajectory:
    """A multi-joint spline starting from ``start`` at absolute time ``start_time``.

    ``points`` times are relative to ``start_time`` and strictly increasing. Points at or before
    ``now`` (when given) are dropped, as the controller drops points already in the past, and the
    first kept segment starts from ``start`` sampled at ``now``.
    """

    def __init__(
        self,
        joints: Sequence[str],
        start: State,
        start_time: float,
        points: Sequence[Point],
        now: float | None = None,
    ) -> None:
        self.joints = tuple(joints)
        n = len(self.joints)
        begin = start_time if now is None else max(start_time, now)
        kept = [p for p in points if start_time + p.time > begin] or list(points[-1:])
        self._times: list[float] = [begin]
        self._coeffs: list[np.ndarray] = []
        prev_p, prev_v, prev_a = start.positions, start.velocities, start.accelerations
        prev_t = begin
        for point in kept:
            p1 = np.asarray(point.positions, dtype=float).reshape(n)
            v1 = _array(point.velocities, n)
            a1 = _array(point.accelerations, n)
            t1 = max(start_time + point.time, prev_t)
            self._coeffs.append(_coefficients(prev_p, prev_v, prev_a, p1, v1, a1, t1 - prev_t))
            self._times.append(t1)
            prev_p = p1
            prev_v = v1 if v1 is not None else np.zeros(n)
            prev_a = a1 if a1 is not None else np.zeros(n)
            prev_t = t1
        self._final = np.asarray(kept[-1].positions, dtype=float) if kept else start.positions
        self._start = start

    @property
    def begin_time(self) -> float:
        return self._times[0]

    @property
    def end_time(self) -> float:
        return self._times[-1]

    @property
    def final_positions(self) -> np.ndarray:
        return self._final

    def sample(self, time: float) -> State:
        n = len(self.joints)
        if time < self._times[0]:
            return self._start
        if time >= self._times[-1]:
            return State(self._final.copy(), np.zeros(n), np.zeros(n))
        index = bisect.bisect_right(self._times, time) - 1
        t = time - self._times[index]
        t2, t3 = t * t, t * t * t
        # Position, velocity and acceleration in one product (sampled at every control update).
        powers = np.array(
            (
                (1.0, t, t2, t3, t2 * t2, t3 * t2),
                (0.0, 1.0, 2.0 * t, 3.0 * t2, 4.0 * t3, 5.0 * t2 * t2),
                (0.0, 0.0, 2.0, 6.0 * t, 12.0 * t2, 20.0 * t3),
            )
        )
        position, velocity, acceleration = powers @ self._coeffs[index]
        return State(position, velocity, acceleration)


def validate_points(points: Sequence[Point], n: int) -> str | None:
    """Why ``points`` cannot be followed (None when they can): sizes, finiteness, increasing times."""
    if not points:
        return "the trajectory has no points"
    last = -math.inf
    for i, point in enumerate(points):
        if not math.isfinite(point.time) or point.time < 0.0:
            return f"point {i}: time_from_start {point.time} is not a finite non-negative time"
        if point.time <= last:
            return f"point {i}: time_from_start {point.time} does not increase (previous {last})"
        last = point.time
        for field in ("positions", "velocities", "accelerations"):
            values = getattr(point, field)
            if values is None or (field != "positions" and len(values) == 0):
                continue
            if len(values) != n:
                return f"point {i}: {len(values)} {field} for {n} joints"
            if not all(math.isfinite(v) for v in values):
                return f"point {i}: {field} are not all finite"
    return None
