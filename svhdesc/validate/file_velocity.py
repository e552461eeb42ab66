"""velocity_tracking on a robot file as it stands (the full tier of `svhdesc validate PATH`).

An MJCF: every velocity servo (an actuator on a joint whose force is kv (ctrl - qdot): MJCF's <velocity>, a wheel's
motor) turns its joint at the velocity commanded, as the built variants' check asks (svhdesc.validate.velocity): from
the rest pose, alone, SHARE of its ctrlrange's end one way, then the other, the other actuators holding their rest
targets, gravity and contacts on; over the last half of RUN s the mean velocity must be within TOLERANCE of the
command. An MJCF without one is skipped.

A URDF (or xacro): each joint its position servo drives (its force the joint's rated effort; a <mimic> follower has
none, and moves with its leader) that states a <limit velocity> > 0 must move at the velocity the file rates it for
with the effort the file rates it for. From the rest pose, alone, its servo follows a ramp at SHARE of that velocity
toward the farther end of its range (a continuous joint's servo range: half a turn), its followers with it, the
other joints holding the rest pose, gravity and contacts on (a floating base held where it rests), for RUN s, or as
long as its servo needs to settle (up to LONGEST s), or until the end. Over the ramp's middle half its mean velocity
must not fall short of the ramp's by more than TOLERANCE (faster, catching up its lag, is no fault). A failure is at
the joint's <limit>, naming the speed against the bound and, where the effort the ramp's speed needs (its damping,
friction, gravity and stiffness, its followers' by their couplings' slopes, by inverse dynamics over the ramp's
middle half) exceeds the rated one, that effort, with the `effort` that would pass (that load from the ramp's start
to the end of its middle half, plus what gets the joint up to speed in the ramp's first eighth) and the `velocity`
whose speed the rated effort carries all the way to the end. Left out, with the reason in the figure, not failed,
where the rated effort would carry the speed (a joint whose effort cannot is ramped, and fails):

- a joint whose ramp is shorter than the time its servo takes to settle: SETTLING x its slowest time constant (the
  roots of M s^2 + (kv + damping) s + kp, M its inertia at rest, its followers' included), plus 4 x the time the
  ramp takes to build the lag whose force starts it (its load at rest: friction, gravity on a limit);
- a joint whose load grows along the ramp's middle half so much that its servo's lag behind the ramp (load / kp)
  alone slows it by more than half the bound (a servo softened for the timestep on a light joint: a gripper's);
- a joint that falls short while what it moves touches anything (its convex hulls dragging on its own robot, a
  gripper's fingers: range_of_motion's question).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from svhdesc.model import velocity_servos
from svhdesc.validate.compile_file import Compiled
from svhdesc.validate.file_motion import _pinned
from svhdesc.validate.findings import CheckResult, Finding
from svhdesc.validate.poses import is_position_servo, rest_state
from svhdesc.validate.range_of_motion import subtree, touching
from svhdesc.validate.velocity import RUN, SHARE, TOLERANCE, tracked

CHECK = "velocity_tracking"
# The ramp must last this many of the servo's time constants: a critically damped servo's mean velocity over the
# ramp's middle half lags the ramp's by [(2 + x) e^-x - (2 + 3x) e^-3x] / 2x at x = duration / 4 tau: 1.4 % at 16
# (an overdamped one's, 2 tau (e^-x - e^-3x) / duration: 0.2 %), of the 5 % allowed.
SETTLING = 16
LONGEST = 4.0  # s: a ramp lasts RUN s, or as long as its servo needs to settle up to this
SAMPLES = 5  # positions over the ramp's middle half where the effort the speed needs is computed
SHOWN_NOTES = 4  # notes the figure lists; the rest are counted


def velocity_tracking(compiled: Compiled) -> CheckResult:
    if compiled.kind == "urdf":
        return _rated_tracking(compiled)
    model = compiled.model
    servos = velocity_servos(model)
    actuators = [a for a in range(model.nu) if model.joint(int(model.actuator_trnid[a, 0])).name in servos]
    if not actuators:
        return CheckResult(CHECK, "skipped", reason="no velocity servo (an actuator with force kv (ctrl - qdot))")
    findings, worst = [], 0.0
    for actuator in actuators:
        joint = model.joint(int(model.actuator_trnid[actuator, 0])).name
        top = float(np.max(np.abs(model.actuator_ctrlrange[actuator]))) if model.actuator_ctrllimited[actuator] else 1.0
        for command in (SHARE * top, -SHARE * top):
            speed = tracked(model, actuator, command, compiled.key)
            error = abs(speed - command) / abs(command) if np.isfinite(speed) else np.inf
            worst = max(worst, error)
            if error > TOLERANCE:
                file, line = compiled.where("rating", joint)
                message = (
                    f"joint '{joint}' turns at {speed:.4g} for a command of {command:.4g} from its velocity servo "
                    f"(mean over the last {RUN / 2:g} s of {RUN:g}; off by {error:.1%}, bound {TOLERANCE:.0%})"
                )
                findings.append(Finding(CHECK, file, line, message))
    figure = f"{len(actuators)} velocity servo(s) at +-{SHARE:g} x their ctrlrange, worst off by {worst:.1%}"
    return CheckResult(CHECK, "fail" if findings else "pass", findings, figure=figure)


@dataclass(frozen=True)
class _Ramp:
    name: str
    joint: int
    actuator: int
    rated: float  # the joint's <limit velocity>
    start: float  # the joint's rest position
    speed: float  # signed: SHARE x rated toward the farther end
    seconds: float
    span: float  # from the rest position to the farther end
    followers: tuple[tuple[int, np.ndarray], ...]  # (joint, polycoef) of each joint equality following it
    bodies: frozenset[int]  # what moves with it


def _followers(model: Any, joint: int) -> tuple[tuple[int, np.ndarray], ...]:
    import mujoco

    return tuple(
        (int(model.eq_obj1id[e]), model.eq_data[e, :5].copy())
        for e in range(model.neq)
        if model.eq_type[e] == mujoco.mjtEq.mjEQ_JOINT and model.eq_obj2id[e] == joint and model.eq_active0[e]
    )


def _mass(model: Any, ramp: _Ramp, rest: Any) -> float:
    """The joint's inertia at rest, its followers' included (each by its coupling's slope), armature too."""
    import mujoco

    inertia = np.zeros((model.nv, model.nv))
    mujoco.mj_fullM(model, rest, inertia)  # MuJoCo 4's signature (model, data, dst)
    slopes = _coupled(model, ramp, rest.qpos.copy())
    dofs, weights = np.array(list(slopes)), np.array(list(slopes.values()))
    return float(weights @ inertia[np.ix_(dofs, dofs)] @ weights)


def _settling(model: Any, ramp: _Ramp, rest: Any) -> tuple[float, str]:
    """How long the servo takes to settle on the ramp (the joint alone, its followers with it, each by its coupling's
    slope at rest): SETTLING x its slowest time constant (the roots of M s^2 + (kv + damping) s + kp), plus 4 x the
    time the ramp takes to build the lag whose force starts it (kp lag = its load at rest: friction, and gravity a
    limit or friction held while the servo, aimed at the rest pose, pushed nothing); and why."""
    kp = float(model.actuator_gainprm[ramp.actuator, 0])
    slopes = _coupled(model, ramp, rest.qpos.copy())
    dofs, weights = np.array(list(slopes)), np.array(list(slopes.values()))
    mass = _mass(model, ramp, rest)
    damping = float(weights**2 @ model.dof_damping[dofs]) - float(model.actuator_biasprm[ramp.actuator, 2])
    load = max(0.0, float(_loads(model, rest, ramp, 0.0, np.array([ramp.start]))[0]))
    discriminant = damping**2 - 4 * mass * kp
    if discriminant <= 0:  # (under or critically) damped: the envelope's
        tau = 2 * mass / damping if damping > 0 else math.inf
    else:  # overdamped: the slow root's (kp / M over the fast one)
        tau = (damping + math.sqrt(discriminant)) / (2 * kp)
    breakaway = load / (kp * abs(ramp.speed))
    why = f"{SETTLING} x its servo's time constant {tau:.3g} s"
    if breakaway > 0:
        why += f" + 4 x the {breakaway:.3g} s its servo (kp {kp:.3g}) takes to build the {load:.3g} that starts it"
    return SETTLING * tau + 4 * breakaway, why


def _ramp(compiled: Compiled, rest: Any, actuator: int) -> _Ramp:
    """From rest toward the farther end at SHARE of the rated velocity, for RUN s or until the end."""
    model = compiled.model
    joint = int(model.actuator_trnid[actuator, 0])
    low, high = model.actuator_ctrlrange[actuator] if model.actuator_ctrllimited[actuator] else (-math.pi, math.pi)
    if model.jnt_limited[joint]:
        low, high = max(low, model.jnt_range[joint, 0]), min(high, model.jnt_range[joint, 1])
    start = float(rest.qpos[model.jnt_qposadr[joint]])
    span, sign = max((high - start, 1.0), (start - low, -1.0))
    rated = compiled.velocity[joint]
    seconds = min(span / (SHARE * rated), RUN) if span > 0 else 0.0
    followers = _followers(model, joint)
    roots = {int(model.jnt_bodyid[j]) for j in (joint, *(f for f, _ in followers))}
    bodies = frozenset(set().union(*(subtree(model, r) for r in roots)))
    speed = sign * SHARE * rated
    return _Ramp(model.joint(joint).name, joint, actuator, rated, start, speed, seconds, span, followers, bodies)


def _ramps(compiled: Compiled, rest: Any) -> tuple[list[_Ramp], list[str]]:
    """The joints to ramp, each for RUN s or as long as its servo needs to settle (up to LONGEST s) or until the end,
    and a note for each left out: its ramp too short for its servo to settle, where its rated effort would carry
    the speed (one that cannot is ramped, and fails)."""
    model, ramps, notes = compiled.model, [], []
    for actuator in range(model.nu):
        joint = int(model.actuator_trnid[actuator, 0])
        if not (compiled.velocity.get(joint, 0.0) > 0 and is_position_servo(model, actuator)):
            continue
        if model.jnt_type[joint] not in (2, 3):
            continue
        ramp = _ramp(compiled, rest, actuator)
        settling, why = _settling(model, ramp, rest)
        seconds = min(ramp.span / abs(ramp.speed), min(max(RUN, settling), LONGEST))
        ramp = replace(ramp, seconds=seconds)
        loads = _loads(model, rest, ramp, ramp.speed, _window(ramp))
        if np.max(loads) > compiled.rated.get(joint, math.inf):  # a fault however the servo settles
            ramps.append(ramp)
        elif (why := _unsettled(model, ramp, loads, settling, why)) is not None:
            unit = "m" if model.jnt_type[joint] == 2 else "rad"
            notes.append(f"'{ramp.name}' left out: its ramp at {abs(ramp.speed):.3g} {unit}/s {why}")
        else:
            ramps.append(ramp)
    return ramps, notes


def _unsettled(model: Any, ramp: _Ramp, loads: np.ndarray, settling: float, why: str) -> str | None:
    """Why the servo cannot follow the ramp within the bound whatever the joint's rating, or None: the ramp ends
    before it settles, or its load grows so much over the ramp's middle half that its lag behind the ramp (the
    load / kp a position servo needs to push it) grows by more than half the bound's share of the way (a servo
    softened for the timestep on a light joint: a gripper's fingers, kp 1.3 N m/rad on its 50 N m)."""
    if ramp.seconds < settling:
        return f"lasts {ramp.seconds:.3g} s, under {why}"
    kp = float(model.actuator_gainprm[ramp.actuator, 0])
    slowing = (loads[-1] - loads[0]) / kp / (abs(ramp.speed) * ramp.seconds / 2)
    if slowing > TOLERANCE / 2:
        return (
            f"slows {slowing:.1%} as its servo (kp {kp:.3g}) lags behind its load's growth ({loads[0]:.3g} to "
            f"{loads[-1]:.3g})"
        )
    return None


def _run(model: Any, data: Any, ramp: _Ramp, pinned: Any) -> tuple[float, dict[tuple[str, str], float]]:
    """The joint's mean velocity over the ramp's middle half (NaN if the model diverges), and the body pairs in
    contact with what it moves on the way there (a pair touching at rest included: convex hulls that overlap drag),
    each with its deepest contact distance."""
    import mujoco

    adr = int(model.jnt_qposadr[ramp.joint])
    steps = max(4, round(ramp.seconds / model.opt.timestep))
    first, last = steps // 4, (3 * steps) // 4
    touched: dict[tuple[str, str], float] = {}
    positions = {}
    for step in range(steps):
        data.ctrl[ramp.actuator] = ramp.start + ramp.speed * step * model.opt.timestep
        mujoco.mj_step(model, data)
        if pinned is not None:
            data.qpos[pinned[0]], data.qvel[pinned[2]] = pinned[1], 0.0
        if step + 1 in (first, last):
            positions[step + 1] = float(data.qpos[adr])
        if first <= step < last and step % 10 == 0:
            for pair, depth in touching(model, data, set(ramp.bodies)).items():
                touched[pair] = min(touched.get(pair, 0.0), depth)
    moved = positions.get(last, np.nan) - positions.get(first, np.nan)
    speed = moved / ((last - first) * model.opt.timestep)
    return (speed if np.all(np.isfinite(data.qpos)) else float("nan")), touched


def _window(ramp: _Ramp) -> np.ndarray:
    """SAMPLES positions over the ramp's middle half."""
    return ramp.start + ramp.speed * ramp.seconds * np.linspace(0.25, 0.75, SAMPLES)


def _coupled(model: Any, ramp: _Ramp, qpos: np.ndarray) -> dict[int, float]:
    """The followers put where their couplings take them from the joint's position in ``qpos``; each dof that moves
    with the joint -> its coupling's slope there (the joint's own: 1)."""
    adr = int(model.jnt_qposadr[ramp.joint])
    slopes = {int(model.jnt_dofadr[ramp.joint]): 1.0}
    for follower, coef in ramp.followers:
        shift, at = qpos[adr] - model.qpos0[adr], int(model.jnt_qposadr[follower])
        qpos[at] = model.qpos0[at] + np.polyval(coef[::-1], shift)
        slopes[int(model.jnt_dofadr[follower])] = float(np.polyval(np.polyder(coef[::-1]), shift))
    return slopes


def _loads(model: Any, rest: Any, ramp: _Ramp, speed: float, positions: np.ndarray) -> np.ndarray:
    """The effort the joint needs at ``positions``, moving at ``speed`` along its ramp, the rest still at rest:
    damping, friction, gravity and stiffness on the joint and on its followers (each by its coupling's slope), by
    inverse dynamics."""
    import mujoco

    data = mujoco.MjData(model)
    adr = int(model.jnt_qposadr[ramp.joint])
    saved = model.opt.disableflags
    model.opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_CONSTRAINT
    loads = []
    try:
        for position in positions:
            data.qpos[:], data.qvel[:], data.qacc[:] = rest.qpos, 0.0, 0.0
            data.qpos[adr] = position
            slopes = _coupled(model, ramp, data.qpos)
            for d, slope in slopes.items():
                data.qvel[d] = slope * speed
            mujoco.mj_inverse(model, data)
            force = sum(slope * float(data.qfrc_inverse[d]) for d, slope in slopes.items())
            friction = sum(abs(slope) * float(model.dof_frictionloss[d]) for d, slope in slopes.items())
            loads.append(math.copysign(1.0, ramp.speed) * force + friction)
    finally:
        model.opt.disableflags = saved
    return np.array(loads)


def _finding(compiled: Compiled, rest: Any, ramp: _Ramp, speed: float, need: float, label: str) -> Finding:
    model = compiled.model
    unit = "m" if model.jnt_type[ramp.joint] == 2 else "rad"
    force = "N" if unit == "m" else "N m"
    file, line = compiled.where("rating", ramp.name)
    message = (
        f"joint '{ramp.name}' moves at {abs(speed):.4g} {unit}/s on a ramp at {abs(ramp.speed):.4g} "
        f"({SHARE:g} x its velocity limit {ramp.rated:g}) from {label}: {_shortfall(ramp, speed):.1%} short, "
        f"bound {TOLERANCE:.0%}"
        if np.isfinite(speed)
        else f"the model diverges while joint '{ramp.name}' follows a ramp at {abs(ramp.speed):.4g} {unit}/s from "
        f"{label} (see model_test, settle)"
    )
    effort = compiled.rated.get(ramp.joint, math.inf)
    if not need > effort:
        return Finding(CHECK, file, line, message)
    message += f"; that speed needs {need:.4g} {force} against its damping, friction and gravity, rated {effort:.4g}"
    # The effort that passes carries the speed from the start of the ramp (a load at rest over the rating holds the
    # joint before the middle half begins) to the end of its middle half, and gets it up to speed in the ramp's
    # first eighth besides.
    way = ramp.start + ramp.speed * ramp.seconds * np.linspace(0.0, 0.75, 2 * SAMPLES)
    carried = max(need, float(np.max(_loads(model, rest, ramp, ramp.speed, way))))
    speeding = _mass(model, ramp, rest) * abs(ramp.speed) / (ramp.seconds / 8)
    remedy = f'effort="{_rounded(carried + speeding, math.ceil)}"'
    # What the speed costs grows as the speed (damping): the speed the rated effort leaves over in every position
    # a slower ramp's middle half may pass (from rest to the farther end).
    path = ramp.start + math.copysign(ramp.span, ramp.speed) * np.linspace(0.0, 1.0, 2 * SAMPLES)
    still = _loads(model, rest, ramp, 0.0, path)
    growth = (_loads(model, rest, ramp, ramp.speed, path) - still) / abs(ramp.speed)
    reach = np.where(growth > 0, (effort - still) / np.where(growth > 0, growth, 1.0), np.inf)
    if np.all(still < effort) and np.isfinite(np.min(reach)):
        remedy += f' or velocity="{_rounded(float(np.min(reach)) / SHARE, math.floor)}"'
    elif np.max(still) > effort:  # no speed helps: the load at rest on the way is over the rating
        message += f" (at rest on its way {float(np.max(still)):.4g}: see gravity_hold)"
    return Finding(CHECK, file, line, message, remedy)


def _rounded(value: float, way: Any) -> str:
    """``value`` rounded up (math.ceil) or down (math.floor) to 3 significant digits: the figure that passes."""
    if value <= 0:
        return "0"
    scale = 10 ** (math.floor(math.log10(value)) - 2)
    return f"{way(value / scale + (-1e-9 if way is math.ceil else 1e-9)) * scale:.4g}"


def _shortfall(ramp: _Ramp, speed: float) -> float:
    """How much slower than its ramp the joint moves, as a share of the ramp's speed (inf: it diverged); moving
    faster (catching up, or gravity's pull: gravity_hold's question) is no shortfall."""
    return 1.0 - speed / ramp.speed if np.isfinite(speed) else math.inf


def _judged(compiled: Compiled, rest: Any, ramp: _Ramp, speed: float, touched: dict, label: str) -> Finding | str:
    """A joint that fell short: a finding where its rated effort cannot carry the speed, or where nothing touches
    what it moves; else a note naming the contact that slows it (range_of_motion's question)."""
    need = float(np.max(_loads(compiled.model, rest, ramp, ramp.speed, _window(ramp))))
    if touched and np.isfinite(speed) and not need > compiled.rated.get(ramp.joint, math.inf):
        moving = {compiled.model.body(b).name for b in ramp.bodies}
        # the deepest, one with a body that does not move with the joint first (two fingers that touch move with it)
        pair = "/".join(min(touched, key=lambda p: (set(p) <= moving, touched[p], p)))
        return f"'{ramp.name}' {_shortfall(ramp, speed):.0%} short, slowed by contact ({pair})"
    return _finding(compiled, rest, ramp, speed, need, label)


def _rated_tracking(compiled: Compiled) -> CheckResult:
    import mujoco

    model = compiled.model
    rest, label = rest_state(model, compiled.key)
    mujoco.mj_forward(model, rest)
    ramps, notes = _ramps(compiled, rest)
    if not ramps:
        why = "; ".join(notes) or "no joint on a position servo states a <limit velocity> > 0"
        return CheckResult(CHECK, "skipped", reason=why)
    data, pinned = mujoco.MjData(model), _pinned(model, rest)
    findings, worst = [], 0.0
    for ramp in ramps:
        mujoco.mj_copyData(data, model, rest)
        mujoco.mj_forward(model, data)
        speed, touched = _run(model, data, ramp, pinned)
        if _shortfall(ramp, speed) <= TOLERANCE:
            worst = max(worst, _shortfall(ramp, speed))
            continue
        judged = _judged(compiled, rest, ramp, speed, touched, label)
        if isinstance(judged, str):
            notes.append(judged)
        else:
            worst = max(worst, _shortfall(ramp, speed))
            findings.append(judged)
    figure = f"{len(ramps)} joint(s) ramped at {SHARE:g} x their velocity limit from {label}, worst {worst:.1%} short"
    if notes:
        more = f" (+{len(notes) - SHOWN_NOTES})" if len(notes) > SHOWN_NOTES else ""
        figure += "; " + "; ".join(notes[:SHOWN_NOTES]) + more
    return CheckResult(CHECK, "fail" if findings else "pass", findings, figure=figure)
