"""The full tier's checks on a compiled robot file: it is simulated, not only read.

- model_test: MuJoCo Menagerie's model test: from qpos0, controls drawn from a Halton sequence within each
  actuator's ctrlrange for 1 s (50 steps at least), and no MuJoCo warning (bad acceleration, contact or constraint
  buffer full, ...), nothing non-finite.
- settle: 1 s (50 steps at least) from the rest pose (keyframe 0, else the zero pose within the limits) holding it:
  the model does not diverge at its own timestep.
- rest_contacts: in no pose the file states (its keyframes; an MJCF's qpos0 without one, when it lies within the
  limits) do two bodies other than a parent and its child interpenetrate deeper than 5 mm. A URDF states no pose:
  skipped, with the pairs that touch in every pose named.
- equality_tracking: every equality constraint (a URDF <mimic>) holds within 5 % of its follower's range (at least
  0.01 rad or m) while the leaders'
  position servos sweep their ranges (rest, upper end, lower end, rest) in 1 s, or slower where a URDF's velocity
  limit asks (at most 10 s), the rest held, contacts off.
- gravity_hold: each joint's rated force (URDF effort, an actuator's force bound) holds its share of the robot's
  weight, by inverse dynamics with the constraints off: a URDF (which states no pose) in at least half of 65 poses
  within the limits (the rest pose and 64 of a Halton sequence), an MJCF in each pose it states (its keyframes,
  else qpos0); a floating-base MJCF is skipped (settle covers it). The value that passes is the worst pose's load.
"""

from __future__ import annotations

import math

import numpy as np

from svhdesc.validate.compile_file import Compiled, quiet_mujoco
from svhdesc.validate.file_motion import CHECK, range_of_motion
from svhdesc.validate.file_velocity import velocity_tracking
from svhdesc.validate.findings import CheckResult, Finding
from svhdesc.validate.poses import contact_pairs, is_position_servo, rest_state, set_pose

FULL_CHECKS = (
    "model_test",
    "settle",
    "rest_contacts",
    "equality_tracking",
    "gravity_hold",
    "range_of_motion",
    "velocity_tracking",
)
MODEL_TEST_SECONDS = 1.0  # Menagerie's _MAX_SIM_TIME
SETTLE_SECONDS = 1.0
MIN_STEPS = 50  # a run is this many steps at least: at a timestep of 0.1 s, 1 s is ten steps, too few to diverge
SWEEP_SECONDS = 1.0
MAX_SWEEP_SECONDS = 10.0
PENETRATION_BOUND = 0.005  # m
# A coupling is broken when its follower strays by 5 % of its range (at least 0.01 rad or m): soft constraints sag a
# few hundredths of a radian on a light fingertip (MuJoCo's default solref on a 2 cm link: 0.16 rad; at 0.004 s:
# 0.04 rad over a 2 rad range), while a coupling that cannot hold strays by tenths.
EQUALITY_FRACTION = 0.05
EQUALITY_FLOOR = 0.01
GRAVITY_SAMPLES = 64


class _Watch:
    """What a run saw: MuJoCo's warnings, non-finite state, each equality's worst residual."""

    def __init__(self, model) -> None:  # type: ignore[no-untyped-def]
        self.model = model
        self.equality = np.zeros(model.neq)
        self.nonfinite_at: float | None = None

    def step(self, data, track: bool = False) -> bool:  # type: ignore[no-untyped-def]
        import mujoco

        mujoco.mj_step(self.model, data)
        if not (np.all(np.isfinite(data.qpos)) and np.all(np.isfinite(data.qvel))):
            self.nonfinite_at = float(data.time)
            return False
        if track:
            rows = np.flatnonzero(data.efc_type[: data.nefc] == mujoco.mjtConstraint.mjCNSTR_EQUALITY)
            if rows.size:
                np.maximum.at(self.equality, data.efc_id[rows], np.abs(data.efc_pos[rows]))
        return True

    def problems(self, data) -> list[str]:  # type: ignore[no-untyped-def]
        import mujoco

        said = [
            f"MuJoCo warning {mujoco.mjtWarning(i).name.removeprefix('mjWARN_')} x{w.number}"
            for i, w in enumerate(data.warning)
            if w.number > 0
        ]
        if self.nonfinite_at is not None:
            said.append(f"the state went non-finite at t={self.nonfinite_at:.4g} s")
            self.nonfinite_at = None
        return said


def _file_finding(compiled: Compiled, check: str, message: str) -> Finding:
    """A run's finding, at the timestep it ran at: an MJCF's <option timestep>, a URDF's <robot> (MuJoCo's
    default timestep: the file states none)."""
    file, line = compiled.where("timestep", "")
    return Finding(check, file, line, message)


def _run_result(compiled: Compiled, check: str, data, watch: _Watch, what: str) -> CheckResult:  # type: ignore[no-untyped-def]
    timestep = compiled.model.opt.timestep
    findings = [_file_finding(compiled, check, f"{what}: {p} (timestep {timestep:g} s)") for p in watch.problems(data)]
    return CheckResult(check, "fail" if findings else "pass", findings, figure=what)


def model_test(compiled: Compiled, watch: _Watch) -> CheckResult:
    """Menagerie's test/model_test.py as its logic reads: from the model's default state (qpos0), each control at
    the centre of its ctrlrange plus its half-width times 2 h - 1, h MuJoCo's Halton point (step, actuator + 2);
    [-1, 1] for an unlimited one; warnings checked at the end."""
    import mujoco

    model = compiled.model
    data = mujoco.MjData(model)
    limited = model.actuator_ctrllimited.astype(bool)
    centre = np.where(limited, model.actuator_ctrlrange.mean(axis=1), 0.0)
    radius = np.where(limited, np.diff(model.actuator_ctrlrange, axis=1)[:, 0] / 2, 1.0)
    steps = max(MIN_STEPS, round(MODEL_TEST_SECONDS / model.opt.timestep))
    for step in range(steps):
        noise = np.array([2 * mujoco.mju_Halton(step, j + 2) - 1 for j in range(model.nu)])
        data.ctrl[:] = centre + radius * noise
        if not watch.step(data):
            break
    what = f"{steps * model.opt.timestep:g} s of Halton controls within ctrlrange from qpos0"
    return _run_result(compiled, "model_test", data, watch, what)


def settle(compiled: Compiled, watch: _Watch) -> CheckResult:
    data, pose = rest_state(compiled.model, compiled.key)
    steps = max(MIN_STEPS, round(SETTLE_SECONDS / compiled.model.opt.timestep))
    for _ in range(steps):
        if not watch.step(data):
            break
    speed = float(np.max(np.abs(data.qvel))) if compiled.model.nv else 0.0
    what = f"{steps * compiled.model.opt.timestep:g} s from {pose}, |qvel| {speed:.3g} at the end"
    result = _run_result(compiled, "settle", data, watch, what)
    if watch.nonfinite_at is None and np.all(np.isfinite(data.qpos)):
        result.findings += _through_floor(compiled, data, what)
        result.status = "fail" if result.findings else result.status
    return result


def _through_floor(compiled: Compiled, data, what: str) -> list[Finding]:  # type: ignore[no-untyped-def]
    """A floating robot (a free joint with an actuated joint below it) whose centre of mass ends below a floor (a
    plane of the world's) it started above: its geometry does not collide with the floor."""
    import mujoco

    model = compiled.model
    planes = [g for g in range(model.ngeom) if model.geom_type[g] == mujoco.mjtGeom.mjGEOM_PLANE]
    free = np.flatnonzero(model.jnt_type == mujoco.mjtJoint.mjJNT_FREE)
    actuated = {int(model.jnt_bodyid[model.actuator_trnid[i, 0]]) for i in range(model.nu)}
    robots = [
        int(model.jnt_bodyid[j]) for j in free if any(_below(model, b, int(model.jnt_bodyid[j])) for b in actuated)
    ]
    if not planes or not robots:
        return []
    start, _ = rest_state(model, compiled.key)
    mujoco.mj_forward(model, start)
    found = []
    for body, plane in ((b, g) for b in robots for g in planes):
        normal, origin = data.geom_xmat[plane].reshape(3, 3)[:, 2], data.geom_xpos[plane]
        after = float((data.subtree_com[body] - origin) @ normal)
        if float((start.subtree_com[body] - origin) @ normal) > 0 > after:
            name, floor = model.body(body).name, model.geom(plane).name or f"plane {plane}"
            file, line = compiled.where("body", name)
            fell = f"body '{name}' falls through the floor '{floor}': its centre of mass ends {-after:.3g} m below it"
            why = "its geometry does not collide with the floor: contype, conaffinity"
            found.append(Finding("settle", file, line, f"{fell} after {what} ({why})"))
    return found


def _below(model, body: int, ancestor: int) -> bool:  # type: ignore[no-untyped-def]
    while body > 0 and body != ancestor:
        body = int(model.body_parentid[body])
    return body == ancestor


def rest_contacts(compiled: Compiled) -> CheckResult:
    import mujoco

    model = compiled.model
    if compiled.kind == "urdf" and not model.nkey:
        listed = ", ".join(f"{a}/{b}" for a, b in compiled.overlapping[:6]) or "none"
        return CheckResult(
            "rest_contacts",
            "skipped",
            reason=f"a URDF states no pose; pairs of links touching in every pose, left out of contact as MoveIt's "
            f"setup assistant disables them: {len(compiled.overlapping)} ({listed})",
        )
    outside = _outside_limits(model)
    if not model.nkey and outside:
        return CheckResult(
            "rest_contacts",
            "skipped",
            reason=f"no keyframe, and qpos0 is no pose of the robot: joint '{outside}' is outside its range there",
        )
    data = mujoco.MjData(model)
    found: dict[tuple[str, str], tuple[float, str]] = {}
    poses = list(range(model.nkey)) or [None]
    for key in poses:
        if key is None:
            data, label = rest_state(model)
        else:
            mujoco.mj_resetDataKeyframe(model, data, key)
            label = f"keyframe '{model.key(key).name or key}'"
        for pair, depth in contact_pairs(model, data).items():
            if depth > found.get(pair, (0.0, ""))[0]:
                found[pair] = (depth, label)
    findings = []
    for (a, b), (depth, label) in sorted(found.items()):
        if depth > PENETRATION_BOUND:
            file, line = compiled.where("body", b if b != "world" else a)
            message = f"bodies '{a}' and '{b}' interpenetrate by {depth * 1000:.3g} mm in {label}"
            findings.append(Finding("rest_contacts", file, line, f"{message} (bound {PENETRATION_BOUND * 1000:g} mm)"))
    deepest = max((d for d, _ in found.values()), default=0.0)
    figure = f"deepest {deepest * 1000:.3g} mm over {len(poses)} pose(s)"
    return CheckResult("rest_contacts", "fail" if findings else "pass", findings, figure=figure)


def _sweep_seconds(compiled: Compiled, servos: list[int], spans: np.ndarray) -> float:
    """SWEEP_SECONDS, or longer where a leader would pass its velocity limit: a cosine segment over a span peaks at
    pi/2 x span / its duration, and the sweep is three segments."""
    model, longest = compiled.model, SWEEP_SECONDS
    for servo, span in zip(servos, spans):
        speed = compiled.velocity.get(int(model.actuator_trnid[servo, 0]))
        if speed:
            longest = max(longest, 3 * (math.pi / 2) * float(span) / speed)
    return min(longest, MAX_SWEEP_SECONDS)


def _outside_limits(model) -> str:  # type: ignore[no-untyped-def]
    """The first 1-dof joint whose qpos0 lies outside its range, or ""."""
    for joint in np.flatnonzero(model.jnt_limited & np.isin(model.jnt_type, (2, 3))):
        q, (lo, hi) = model.qpos0[model.jnt_qposadr[joint]], model.jnt_range[joint]
        if q < lo - 1e-9 or q > hi + 1e-9:
            return str(model.joint(joint).name or joint)
    return ""


def equality_tracking(compiled: Compiled, watch: _Watch) -> CheckResult:
    import mujoco

    model = compiled.model
    couplings = np.flatnonzero(model.eq_type == mujoco.mjtEq.mjEQ_JOINT)
    if couplings.size == 0:  # a weld to a mocap body drives the robot; it couples no joints
        return CheckResult("equality_tracking", "skipped", reason="no joint couplings (<mimic>, <equality><joint>)")
    data, _ = rest_state(model, compiled.key)
    leaders = {int(model.eq_obj2id[e]) for e in couplings}
    servos = [  # the leaders' servos sweep; every other joint is held where it rests
        i
        for i in range(model.nu)
        if is_position_servo(model, i) and model.actuator_ctrllimited[i] and int(model.actuator_trnid[i, 0]) in leaders
    ]
    lo, hi = model.actuator_ctrlrange[servos, 0], model.actuator_ctrlrange[servos, 1]
    # From where each servo rests to its upper end, its lower end and back, smoothly: no step in the target.
    waypoints = np.array([data.ctrl[servos], hi, lo, data.ctrl[servos]])
    seconds = _sweep_seconds(compiled, servos, hi - lo)
    steps = max(3, round(seconds / model.opt.timestep))
    saved = model.opt.disableflags
    # Without contacts: fingers meeting each other is how a gripper closes, and what blocks a joint is
    # range_of_motion's question; this one asks whether the couplings hold while everything moves.
    model.opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_CONTACT
    try:
        for step in range(steps):
            segment, fraction = divmod(3 * step / steps, 1.0)
            start, end = waypoints[int(segment)], waypoints[int(segment) + 1]
            data.ctrl[servos] = start + (end - start) * 0.5 * (1 - math.cos(math.pi * fraction))
            if not watch.step(data, track=True):
                break
    finally:
        model.opt.disableflags = saved
    findings = []
    bounds = np.array([_equality_bound(model, e) for e in range(model.neq)])
    for e in couplings[watch.equality[couplings] > bounds[couplings]]:
        name = model.eq(e).name
        joint = model.joint(model.eq_obj1id[e]).name if model.eq_type[e] == mujoco.mjtEq.mjEQ_JOINT else ""
        file, line = compiled.where("equality", name or joint) if compiled.kind == "mjcf" else (None, None)
        if file is None:
            file, line = compiled.where("joint", joint)
        label = f"equality '{name}'" if name else f"joint '{joint}' (its coupling)"
        message = f"{label} off by up to {watch.equality[e]:.3g} while the leaders sweep their ranges in"
        findings.append(Finding("equality_tracking", file, line, f"{message} {seconds:.3g} s (bound {bounds[e]:.3g})"))
    figure = f"worst residual {float(np.max(watch.equality[couplings])):.3g} over a {seconds:.3g} s sweep"
    return CheckResult("equality_tracking", "fail" if findings else "pass", findings, figure=figure)


def _equality_bound(model, equality: int) -> float:  # type: ignore[no-untyped-def]
    import mujoco

    joint = int(model.eq_obj1id[equality])
    if model.eq_type[equality] != mujoco.mjtEq.mjEQ_JOINT or not model.jnt_limited[joint]:
        return EQUALITY_FLOOR
    lo, hi = model.jnt_range[joint]
    return max(EQUALITY_FLOOR, EQUALITY_FRACTION * float(hi - lo))


def gravity_hold(compiled: Compiled) -> CheckResult:
    """A URDF states no pose: its joints must hold their load in most of the sampled poses. An MJCF states its
    poses (keyframes, else qpos0): its actuators must hold each of them. A floating base is held by the floor,
    which settle covers; the load on its joints depends on how it stands, so it is not judged here."""
    import mujoco

    model = compiled.model
    left_out = {n for n, j in compiled.joints.items() if "gravity_hold" in j.ignore}
    rated = {
        j: f for j, f in compiled.rated.items() if model.jnt_type[j] in (2, 3) and model.joint(j).name not in left_out
    }
    if not rated:
        return CheckResult("gravity_hold", "skipped", reason="no joint states a force it is rated for")
    if compiled.kind == "mjcf" and np.any(model.jnt_type == mujoco.mjtJoint.mjJNT_FREE):
        return CheckResult("gravity_hold", "skipped", reason="a floating base: the floor holds it (see settle)")
    poses, label = _stated_poses(compiled)
    saved = model.opt.disableflags
    model.opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_CONSTRAINT  # the actuators alone hold the weight
    try:
        loads = _holding_loads(model, list(rated), poses)
    finally:
        model.opt.disableflags = saved
    judged = {j: float(np.median(v) if compiled.kind == "urdf" else np.max(v)) for j, v in loads.items()}
    findings = []
    for joint, force in rated.items():
        if judged[joint] > force:
            name = model.joint(joint).name
            file, line = compiled.where("rating", name)  # where the rating is written: <limit effort>, an actuator
            unit = "N m" if model.jnt_type[joint] == mujoco.mjtJoint.mjJNT_HINGE else "N"
            worst = float(np.max(loads[joint]))
            message = (
                f"joint '{name}' is rated {force:.4g} {unit} but needs {judged[joint]:.4g} to hold against "
                f"gravity in {label} (worst {worst:.4g})"
            )
            findings.append(Finding("gravity_hold", file, line, message, _remedy(compiled, worst)))
    ratio = max(judged[j] / f for j, f in rated.items())
    figure = f"load up to {ratio:.3g} x rated in {label}"
    return CheckResult("gravity_hold", "fail" if findings else "pass", findings, figure=figure)


def _stated_poses(compiled: Compiled) -> tuple[list[np.ndarray], str]:
    """The poses a gravity load is judged in, and how the finding names them."""
    import mujoco

    model = compiled.model
    data, _ = rest_state(model)
    if compiled.kind == "mjcf":
        if model.nkey:
            return [model.key_qpos[k].copy() for k in range(model.nkey)], f"its {model.nkey} keyframe(s)"
        return [data.qpos.copy()], "its rest pose (qpos0)"
    poses = [data.qpos.copy()]
    for sample in range(1, GRAVITY_SAMPLES + 1):
        set_pose(model, data, sample)
        poses.append(data.qpos.copy())
    mujoco.mj_resetData(model, data)
    return poses, f"most of {GRAVITY_SAMPLES + 1} poses (median)"


def _holding_loads(model, joints: list[int], poses: list[np.ndarray]) -> dict[int, np.ndarray]:  # type: ignore[no-untyped-def]
    """Each joint's generalized force holding the robot still against gravity, in each pose."""
    import mujoco

    data = mujoco.MjData(model)
    loads = {joint: np.zeros(len(poses)) for joint in joints}
    for index, qpos in enumerate(poses):
        data.qpos[:] = qpos
        data.qvel[:] = 0
        data.qacc[:] = 0
        mujoco.mj_inverse(model, data)
        for joint in joints:
            loads[joint][index] = abs(float(data.qfrc_inverse[model.jnt_dofadr[joint]]))
    return loads


def _remedy(compiled: Compiled, need: float) -> str:
    if compiled.kind == "urdf":
        return f'effort="{_round_up(need)}"'
    return f"a force bound (forcerange x gear) of at least {_round_up(need)}"


def _round_up(value: float) -> str:
    """``value`` rounded up to 3 significant digits: the figure that passes."""
    if value <= 0:
        return "0"
    scale = 10 ** (math.floor(math.log10(value)) - 2)
    return f"{math.ceil(value / scale - 1e-9) * scale:.4g}"


def run_full_checks(compiled: Compiled) -> list[CheckResult]:
    watch = _Watch(compiled.model)
    with quiet_mujoco():
        results = [model_test(compiled, watch), settle(compiled, watch), rest_contacts(compiled)]
        results += [equality_tracking(compiled, watch), gravity_hold(compiled)]
        results.append(range_of_motion(compiled, *joint_quirks(compiled)))
        results.append(velocity_tracking(compiled))
    return results


def joint_quirks(compiled: Compiled) -> tuple[dict[str, float], dict[str, str]]:
    """The settings' range_of_motion tolerances and the joints they leave out of it (with why)."""
    tolerances = {n: j.tolerance for n, j in compiled.joints.items() if j.tolerance is not None}
    left_out = {n: j.ignore[CHECK] for n, j in compiled.joints.items() if CHECK in j.ignore}
    return tolerances, left_out
