"""How ``svhdesc init`` sizes an independent joint's position servo, from the source and the loads at ``home``.

- kp = effort / STIFF_AT (full effort 0.1 rad, or 5 mm, from the target);
- capped so that the servo's natural frequency on the inertia behind the joint at ``home`` stays within what the
  timestep integrates: sqrt(kp / I) * dt <= MAX_OMEGA_DT. MuJoCo integrates a servo's stiffness explicitly; the
  finger of example-robot-data's finger_edu, rated 1000 N m on 10^-4 kg m^2, rang at 10^4 rad/s against a 2 ms step
  and blew up (mjWARN_BADQACC) with kp = 10^4; the cap gives it 6.2;
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
MAX_OMEGA_DT = 0.5  # the servo's natural frequency times the timestep, at most (explicit stiffness: unstable by 2)
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


def size_drive(kind: str, effort: float, velocity: float, load: Load | None, timestep: float) -> Drive:
    """The servo of one joint of type ``kind`` rated ``effort`` and ``velocity`` (0: unrated) carrying ``load`` at
    home (None: unknown), for a model stepped at ``timestep``."""
    guessed, raised = effort <= 0 or velocity <= 0, False
    held = HOLD_MARGIN * abs(load.gravity) if load is not None else 0.0
    if guessed:
        moved = MIN_ACCELERATION * load.inertia if load is not None else 0.0
        effort = _round(max(held, moved, 1e-3))
        velocity = GUESSED_VELOCITY[kind]
    elif held > effort:
        effort, raised = _round(held), True
    kp = round(effort / STIFF_AT[kind], 3)
    limit = load.inertia * (MAX_OMEGA_DT / timestep) ** 2 if load is not None and load.inertia > 0 else math.inf
    if kp > limit:
        return Drive(_round(limit), effort, velocity, guessed, True, raised)
    return Drive(kp, effort, velocity, guessed, False, raised)


def natural_frequency(kp: float, inertia: float) -> float:
    return math.sqrt(kp / inertia) if inertia > 0 else math.inf
