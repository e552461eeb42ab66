"""How ``svhdesc init`` sizes an independent joint's position servo, from the source and the loads at ``home``.

- kp = effort / STIFF_AT (full effort 0.1 rad, or 5 mm, from the target);
- capped so that the servos' natural frequencies on the robot's inertia at ``home`` stay within what the timestep
  integrates. MuJoCo integrates a servo's stiffness explicitly: the step is unstable once omega * dt passes 2, and
  the build refuses a model its step cannot integrate (svhdesc/compiler/probes/stability.py). The frequencies are
  the eigenvalues of M^-1 K (M the joint-space mass matrix, K the servos' kp), which are at most its trace,
  sum kp_i (M^-1)_ii; the kps are cut, the largest terms first (water-filling), until that sum times dt^2 is
  MAX_TRACE, each term relaxed by the damping init writes for the joint (``cap_stiffness``). The finger of
  example-robot-data's finger_edu, rated 1000 N m on 10^-4 kg m^2, rang at 10^4 rad/s against a 2 ms step and blew
  up (mjWARN_BADQACC) with kp = 10^4;
- a joint whose rated effort cannot hold what gravity puts on it at ``home`` gets ``joints.NAME.effort`` =
  HOLD_MARGIN x that load, stated in the config as a deviation from the source (Baxter's shoulder ``s1``, rated
  50 N m, carries about 53 N m of its outstretched arm; the real arm has a spring for it): without it the model sags
  271 mrad at home;
- a joint the source rates no drive for (``<limit effort="0">`` or velocity 0, as pybullet's demo robots write) gets
  ``joints.NAME.effort`` = HOLD_MARGIN x the gravity load at ``home`` (at least the effort that accelerates its load at
  MIN_ACCELERATION) and ``joints.NAME.velocity`` = GUESSED_VELOCITY: a stated guess, so that the robot holds itself.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from svhdesc.compiler.loads import Load

STIFF_AT = {"revolute": 0.1, "continuous": 0.1, "prismatic": 0.005}
MAX_TRACE = 0.81  # sum kp_i (M^-1)_ii dt^2 at most: every undamped omega * dt <= 0.9
MIN_ACCELERATION = 10.0  # rad/s^2 (m/s^2): what a guessed drive can give its load at least
HOLD_MARGIN = 1.5  # a drive holds this multiple of its gravity load at home
GUESSED_VELOCITY = {"revolute": 1.0, "continuous": 1.0, "prismatic": 0.1}  # rad/s, m/s


@dataclass(frozen=True)
class Drive:
    kp: float
    effort: float  # the joint's effort: the source's, or a guess where it rates none
    velocity: float
    guessed: bool  # effort and velocity guessed (the source rates no drive)
    capped: bool  # kp held below effort / STIFF_AT by the timestep
    raised: bool = False  # effort raised above the source's rating to hold the robot at home


def _round(value: float) -> float:
    return float(f"{value:.4g}")


def _round_down(value: float) -> float:
    """``value`` to 4 significant digits, never above it (a cap must hold)."""
    rounded = _round(value)
    if rounded <= value:
        return rounded
    step = 10.0 ** (math.floor(math.log10(value)) - 3)
    return float(f"{rounded - step:.4g}")


def size_drive(kind: str, effort: float, velocity: float, load: Load | None) -> Drive:
    """The servo of one joint of type ``kind`` rated ``effort`` and ``velocity`` (0: unrated) carrying ``load`` at
    home (None: unknown), before the timestep's cap (``cap_stiffness``)."""
    guessed, raised = effort <= 0 or velocity <= 0, False
    held = HOLD_MARGIN * abs(load.gravity) if load is not None else 0.0
    if guessed:
        moved = MIN_ACCELERATION * load.inertia if load is not None else 0.0
        effort = _round(max(held, moved, 1e-3))
        velocity = GUESSED_VELOCITY[kind]
    elif held > effort:
        effort, raised = _round(held), True
    return Drive(round(effort / STIFF_AT[kind], 3), effort, velocity, guessed, False, raised)


def cap_stiffness(
    drives: dict[str, Drive],
    mobility: dict[str, float],
    timestep: float,
    damping: dict[str, float] | None = None,
    fixed: float = 0.0,
) -> dict[str, Drive]:
    """``drives`` with the largest terms kp_i (M^-1)_ii dt^2 / (1 + dt c_i (M^-1)_ii / 2) cut to one level, so that
    their sum, with ``fixed`` (the terms of servos not sized here: a hand's channels), is MAX_TRACE; ``mobility``:
    (M^-1)_ii per joint, ``damping``: c_i, the joint damping init writes (MuJoCo integrates it implicitly, which
    widens the stable range of one joint to omega^2 dt^2 < 4 + 2 dt c / m: a light joint damped hard takes a stiff
    servo)."""
    damping = damping or {}
    allowance = {n: 1.0 + timestep * damping.get(n, 0.0) * mobility.get(n, 0.0) / 2.0 for n in drives}
    terms = {n: d.kp * mobility.get(n, 0.0) * timestep**2 / allowance[n] for n, d in drives.items()}
    budget = MAX_TRACE - fixed
    if sum(terms.values()) <= budget or budget <= 0:
        return drives
    ordered = sorted(terms.values(), reverse=True)
    level, rest = 0.0, sum(ordered)
    for count, term in enumerate(ordered, start=1):  # the level t with sum(min(term, t)) = budget
        rest -= term
        level = (budget - rest) / count
        if count == len(ordered) or level >= ordered[count]:
            break
    capped = {}
    for name, drive in drives.items():
        if terms[name] > level:
            kp = _round_down(level * allowance[name] / (mobility[name] * timestep**2))
            capped[name] = Drive(kp, drive.effort, drive.velocity, drive.guessed, True, drive.raised)
        else:
            capped[name] = drive
    return capped
