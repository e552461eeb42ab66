"""Check 8, the thesis experiment: the index fingertip presses a fixed surface; joints must stay still.

The robot is driven from keyframe ``home`` to ``test`` by its position actuators (control ramped over
RAMP s). A static box is added so that its face sits DEPTH inside the fingertip's collision geometry
in the ``test`` pose; the servos then press the tip into it. After SETTLE s, joint positions and the
fingertip's normal force are recorded for RECORD s. Per joint, the mean absolute deviation from the
running average of the last WINDOW samples (thesis eq. 5.1) must stay below MAD_BOUND; the force
must be positive and steady.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..polynomial import polyval
from .options import Options
from .pair import ModelPair, joint_equalities, scalar_joints
from .report import Check, fmt, not_run, table, verdict

RAMP = 1.0  # s, home -> test control ramp
SETTLE = 2.0  # s after the ramp before recording
RECORD = 2.0  # s recorded
DEPTH = 0.0025  # m the surface sits inside the fingertip in the test pose
THICKNESS = 0.01  # m half thickness of the box
WINDOW = 10  # samples in the running average of eq. 5.1
MAD_BOUND = 1e-9  # rad
FORCE_CV_BOUND = 0.02  # std / mean of the normal force
PAD_HALF_WIDTH = 0.004  # m: a pad-side surface covers the fingertip pad only
TABLE_HALF_WIDTH = 0.05  # m: an approached surface is a small table the tip may slide on
MOVES = 0.01  # m: a fingertip that travels farther than this from home to test approaches the surface
SURFACE = "svhdesc_validate_surface"


def mad(series: np.ndarray, window: int = WINDOW) -> np.ndarray:
    """Thesis eq. 5.1 per column: mean |x_i - xbar_i|, xbar_i the mean of samples i-window+1..i."""
    cumulative = np.cumsum(np.vstack([np.zeros((1, series.shape[1])), series]), axis=0)
    running = (cumulative[window:] - cumulative[:-window]) / window
    return np.abs(series[window - 1 :] - running).mean(axis=0)


class SetupError(Exception):
    """The model lacks what the experiment needs (touch sensor, keyframes, fingertip geometry)."""


@dataclass
class Experiment:
    """What one run recorded; kept for the plots and the JSON report."""

    joints: list[str]
    time: np.ndarray
    qpos: np.ndarray  # samples x joints, whole run
    force: np.ndarray  # normal force on the fingertip from the surface, whole run
    touch: np.ndarray  # touch sensor, whole run
    record_from: int  # first recorded sample
    setup: dict[str, Any] = field(default_factory=dict)
    nan_at: float | None = None
    warnings: dict[str, int] = field(default_factory=dict)


def _touch_site(model: Any) -> int | None:
    import mujoco

    for sensor in range(model.nsensor):
        if int(model.sensor_type[sensor]) == int(mujoco.mjtSensor.mjSENS_TOUCH):
            return int(model.sensor_objid[sensor])
    return None


def _geom_points(model: Any, data: Any, geom: int) -> np.ndarray:
    """World points bounding a geom: mesh vertices, else the corners of its local bounding box."""
    import mujoco

    rotation = data.geom_xmat[geom].reshape(3, 3)
    if int(model.geom_type[geom]) == int(mujoco.mjtGeom.mjGEOM_MESH) and model.geom_dataid[geom] >= 0:
        mesh = model.geom_dataid[geom]
        start, count = model.mesh_vertadr[mesh], model.mesh_vertnum[mesh]
        local = model.mesh_vert[start : start + count].astype(float)
    else:
        centre, half = model.geom_aabb[geom, :3], model.geom_aabb[geom, 3:]
        corners = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)])
        local = centre + corners * half
    return data.geom_xpos[geom] + local @ rotation.T


def _tip_points(model: Any, data: Any, geoms: list[int]) -> np.ndarray:
    return np.vstack([_geom_points(model, data, g) for g in geoms])


def _leading_channel(model: Any, body: int) -> tuple[int, list[tuple[int, tuple[float, ...]]]]:
    """The channel joint nearest above the body (a coupled joint leads to its channel), and its followers."""
    equalities = joint_equalities(model)
    follows = {model.joint(e.joint).id: model.joint(e.channel).id for e in equalities}
    while body > 0 and model.body_jntnum[body] == 0:
        body = model.body_parentid[body]
    joint = int(model.body_jntadr[body]) if body > 0 else -1
    channel = follows.get(joint, joint)
    followers = [(model.joint(e.joint).id, e.coeffs) for e in equalities if model.joint(e.channel).id == channel]
    return channel, followers


def _direction(model: Any, data: Any, tip: int, geoms: list[int], home: int, test: int) -> tuple[np.ndarray, str]:
    """The direction in which the surface lies, seen from the fingertip in the test pose.

    A fingertip that the arm carries from home to test approaches the surface: the direction of that
    final approach (a box on the pad side would be swept through by the hand on its way). A fingertip
    that stays put presses with its pad: the direction it moves when its distal channel flexes."""
    import mujoco

    def points_at(qpos: np.ndarray) -> np.ndarray:
        data.qpos[:] = qpos
        mujoco.mj_kinematics(model, data)
        return _tip_points(model, data, geoms)

    q_home, q_test = model.key_qpos[home].copy(), model.key_qpos[test].copy()
    at_test = points_at(q_test)
    travel = float(np.linalg.norm(at_test.mean(axis=0) - points_at(q_home).mean(axis=0)))
    if travel > MOVES:
        before = points_at(q_home + 0.9 * (q_test - q_home))
        direction = at_test.mean(axis=0) - before.mean(axis=0)
        how = f"approach direction (the fingertip travels {travel * 100:.1f} cm from home to test)"
    else:
        channel, followers = _leading_channel(model, tip)
        if channel < 0:
            raise SetupError("no joint above the fingertip to tell where its pad faces")
        q = q_test.copy()
        step = 1e-3
        q[model.jnt_qposadr[channel]] += step
        for joint, coeffs in followers:
            q[model.jnt_qposadr[joint]] = polyval(coeffs, q[model.jnt_qposadr[channel]])
        direction = (points_at(q) - at_test).mean(axis=0)
        how = f"pad direction (motion of the tip when {model.joint(channel).name} flexes)"
    norm = float(np.linalg.norm(direction))
    if norm == 0:
        raise SetupError("the fingertip does not move; cannot tell where to put the surface")
    data.qpos[:] = q_test
    mujoco.mj_kinematics(model, data)
    return direction / norm, how


def _frame(normal: np.ndarray) -> np.ndarray:
    """Rotation whose z axis is ``normal``."""
    helper = np.array([0.0, 0.0, 1.0]) if abs(normal[2]) < 0.9 else np.array([1.0, 0.0, 0.0])
    x = np.cross(helper, normal)
    x /= np.linalg.norm(x)
    return np.column_stack([x, np.cross(normal, x), normal])


def run_experiment(pair: ModelPair) -> Experiment:
    import mujoco

    from .simulate import warning_counts

    model = pair.model
    site = _touch_site(model)
    if site is None:
        raise SetupError("the MJCF has no touch sensor to find the fingertip by")
    home = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_KEY, "home")
    test = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_KEY, "test")
    if home < 0 or test < 0:
        raise SetupError("the MJCF lacks keyframe 'home' or 'test'")
    tip = int(model.site_bodyid[site])
    geoms = [
        g
        for g in range(model.ngeom)
        if model.geom_bodyid[g] == tip and (model.geom_contype[g] or model.geom_conaffinity[g])
    ]
    if not geoms:
        raise SetupError(f"fingertip body {model.body(tip).name} has no collision geometry")
    data = mujoco.MjData(model)
    normal, how = _direction(model, data, tip, geoms, home, test)
    points = _tip_points(model, data, geoms)
    heights = points @ normal
    reach = float(heights.max())
    # Centre the surface under the part of the tip that will touch (the points within DEPTH of the
    # extreme): a pad-side surface as wide as the whole tip would also catch the next phalanx.
    centre = points[heights >= reach - max(DEPTH, 1e-4)].mean(axis=0)
    half_width = TABLE_HALF_WIDTH if how.startswith("approach") else PAD_HALF_WIDTH
    rotation = _frame(-normal)  # box z axis points back at the finger: its +z face is the surface
    face = reach - DEPTH
    position = centre + normal * (face + THICKNESS - centre @ normal)
    quat = np.zeros(4)
    mujoco.mju_mat2Quat(quat, rotation.flatten())

    spec = mujoco.MjSpec.from_file(str(pair.mjcf_path))
    surface = spec.worldbody.add_geom()
    surface.name = SURFACE
    surface.type = mujoco.mjtGeom.mjGEOM_BOX
    surface.size = [half_width, half_width, THICKNESS]
    surface.pos = position
    surface.quat = quat
    surface.rgba = [0.7, 0.7, 0.7, 1.0]
    surface.group = 3  # collision: keep it out of renders
    scene = spec.compile()
    box = mujoco.mj_name2id(scene, mujoco.mjtObj.mjOBJ_GEOM, SURFACE)
    sdata = mujoco.MjData(scene)
    tip_geoms = {int(g) for g in range(scene.ngeom) if scene.geom_bodyid[g] == tip}

    mujoco.mj_resetDataKeyframe(scene, sdata, test)
    mujoco.mj_forward(scene, sdata)
    others = sorted(
        {
            scene.body(scene.geom_bodyid[c.geom1 if c.geom2 == box else c.geom2]).name
            for c in sdata.contact[: sdata.ncon]
            if box in (c.geom1, c.geom2)
        }
        - {scene.body(tip).name}
    )

    mujoco.mj_resetDataKeyframe(scene, sdata, home)
    start, goal = scene.key_ctrl[home].copy(), scene.key_ctrl[test].copy()
    dt = scene.opt.timestep
    total = int(round((RAMP + SETTLE + RECORD) / dt))
    record_from = total - int(round(RECORD / dt))
    joints = scalar_joints(scene)
    addresses = scene.jnt_qposadr[joints]
    touch_adr = next(
        int(scene.sensor_adr[s])
        for s in range(scene.nsensor)
        if int(scene.sensor_type[s]) == int(mujoco.mjtSensor.mjSENS_TOUCH)
    )
    qpos = np.zeros((total, len(joints)))
    force, touch = np.zeros(total), np.zeros(total)
    wrench = np.zeros(6)
    nan_at = None
    for step in range(total):
        sdata.ctrl[:] = start + (goal - start) * min(1.0, step * dt / RAMP)
        mujoco.mj_step(scene, sdata)
        if not np.isfinite(sdata.qpos).all():
            nan_at = step * dt
            qpos, force, touch = qpos[:step], force[:step], touch[:step]
            break
        qpos[step] = sdata.qpos[addresses]
        normal_force = 0.0
        for index, contact in enumerate(sdata.contact[: sdata.ncon]):
            if (contact.geom1 == box and contact.geom2 in tip_geoms) or (
                contact.geom2 == box and contact.geom1 in tip_geoms
            ):
                mujoco.mj_contactForce(scene, sdata, index, wrench)
                normal_force += wrench[0]
        force[step] = normal_force
        touch[step] = sdata.sensordata[touch_adr]
    setup = {
        "fingertip": scene.body(tip).name,
        "direction": normal.tolist(),
        "direction_from": how,
        "surface_pos": position.tolist(),
        "surface_half_size": [half_width, half_width, THICKNESS],
        "depth_m": DEPTH,
        "other_bodies_touching_at_test": others,
        "ramp_s": RAMP,
        "settle_s": SETTLE,
        "record_s": RECORD,
        "timestep": dt,
    }
    return Experiment(
        [scene.joint(j).name for j in joints],
        np.arange(len(force)) * dt + dt,
        qpos,
        force,
        touch,
        record_from,
        setup,
        nan_at,
        warning_counts(sdata),
    )


def check_contact_stability(pair: ModelPair, options: Options) -> list[Check]:
    bound = f"MAD <= {MAD_BOUND:g} rad, F > 0, std/F <= {FORCE_CV_BOUND:.0%}"
    if pair.model is None:
        return [not_run("contact_stability", "the MJCF does not compile", bound)]
    try:
        run = run_experiment(pair)
    except SetupError as exc:
        return [not_run("contact_stability", str(exc), bound)]
    if run.nan_at is not None:
        return [
            Check("contact_stability", "fail", "NaN", bound, f"NaN at t = {run.nan_at:.3f} s", {"setup": run.setup})
        ]
    recorded = run.qpos[run.record_from :]
    deviations = mad(recorded)
    means = recorded.mean(axis=0)
    force = run.force[run.record_from :]
    touch = run.touch[run.record_from :]
    force_mean, force_std = float(force.mean()), float(force.std())
    variation = force_std / force_mean if force_mean > 0 else float("inf")
    joints = {
        name: {"mad_rad": float(m), "mean_rad": float(x), "pass": bool(m <= MAD_BOUND)}
        for name, m, x in zip(run.joints, deviations, means, strict=True)
    }
    moving = [n for n, v in joints.items() if not v["pass"]]
    problems = []
    if moving:
        problems.append(
            f"{len(moving)} of {len(joints)} joints above the MAD bound (worst "
            f"{run.joints[int(np.argmax(deviations))]} {deviations.max():.3g} rad)"
        )
    if force_mean <= 0:
        problems.append("no normal force on the fingertip: it does not reach the surface")
    elif variation > FORCE_CV_BOUND:
        problems.append(f"normal force varies {variation:.2%} (std {force_std:.3g} N)")
    if run.warnings:
        problems.append("MuJoCo warnings " + ", ".join(f"{k} x{v}" for k, v in run.warnings.items()))
    if run.setup["other_bodies_touching_at_test"]:
        problems.append(
            f"the surface also touches {', '.join(run.setup['other_bodies_touching_at_test'])} in the test pose"
        )
    rows = [
        [name, f"{v['mad_rad']:.3e}", f"{v['mean_rad']:+.6f}", "pass" if v["pass"] else "FAIL"]
        for name, v in joints.items()
    ]
    text = table(rows, ["joint", "MAD [rad]", "mean [rad]", "status"])
    text += (
        f"\nnormal force on {run.setup['fingertip']}: mean {force_mean:.4g} N, std {force_std:.3g} N "
        f"({variation:.3%}); touch sensor mean {touch.mean():.4g} N, std {touch.std():.3g} N"
        f"\nsurface along {np.array2string(np.array(run.setup['direction']), precision=3)}: "
        f"{run.setup['direction_from']}"
    )
    if options.plots is not None:
        from .plots import plot_contact

        run.setup["plots"] = [str(p) for p in plot_contact(run, pair.name, options.plots)]
    figures = {
        "joints": joints,
        "force_mean_n": force_mean,
        "force_std_n": force_std,
        "force_variation": variation,
        "touch_mean_n": float(touch.mean()),
        "touch_std_n": float(touch.std()),
        "samples": int(len(force)),
        "window": WINDOW,
        "setup": run.setup,
        "warnings": run.warnings,
    }
    measured = f"max MAD {fmt(float(deviations.max()))} rad, F {force_mean:.3g} N +- {variation:.2%}"
    detail = "; ".join(problems) or f"{len(joints)} joints still, {run.setup['direction_from']}"
    return [Check("contact_stability", verdict(not problems), measured, bound, detail, figures, table=text)]
