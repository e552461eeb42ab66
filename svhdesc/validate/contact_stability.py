"""Check 8, the thesis experiment: the index fingertip presses a fixed surface; joints must stay still.

The robot is driven from keyframe ``home`` to ``test`` by its position actuators (control ramped over
RAMP s). A static box is added so that its face sits DEPTH inside the fingertip's collision geometry
in the ``test`` pose; the servos then press the tip into it. After SETTLE s, joint positions and the
fingertip's normal force are recorded for RECORD s. Per joint, the mean absolute deviation from the
running average of the WINDOW samples around it (thesis eq. 5.1, centred) must stay below MAD_BOUND; the force
must be positive and steady. The experiment itself (surface placement, ramp, schedule, eq. 5.1) is
defined in ``svhdesc.compare.experiment``, shared with ``svhdesc compare``.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from svhdesc.compare import experiment as shared
from svhdesc.compare.experiment import WINDOW, SetupError, mad
from svhdesc.validate.options import Options
from svhdesc.validate.pair import ModelPair, scalar_joints
from svhdesc.validate.report import Check, fmt, not_run, skipped, table, verdict

MAD_BOUND = 1e-9  # rad
FORCE_CV_BOUND = 0.02  # std / mean of the normal force

__all__ = ["Experiment", "SetupError", "check_contact_stability", "mad", "run_experiment"]


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


def run_experiment(pair: ModelPair) -> Experiment:
    import mujoco

    from svhdesc.validate.simulate import warning_counts

    model = pair.model
    home, test = shared.keyframes(model)
    tip, _ = shared.fingertip(model)
    surface = shared.place_surface(model)

    spec = mujoco.MjSpec.from_file(str(pair.mjcf_path))
    shared.add_surface(spec, surface)
    scene = spec.compile()
    box = mujoco.mj_name2id(scene, mujoco.mjtObj.mjOBJ_GEOM, shared.SURFACE)
    sdata = mujoco.MjData(scene)
    tip_geoms = {int(g) for g in range(scene.ngeom) if scene.geom_bodyid[g] == tip}

    mujoco.mj_resetDataKeyframe(scene, sdata, test)
    mujoco.mj_forward(scene, sdata)
    others = sorted(shared.bodies_touching(scene, sdata, box) - {scene.body(tip).name})

    mujoco.mj_resetDataKeyframe(scene, sdata, home)
    start, goal = scene.key_ctrl[home].copy(), scene.key_ctrl[test].copy()
    dt = scene.opt.timestep
    total, record_from, _ = shared.schedule(dt)
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
        sdata.ctrl[:] = shared.ramp(start, goal, step, dt)
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
        "direction": surface.normal.tolist(),
        "direction_from": surface.direction_from,
        "surface_pos": surface.position.tolist(),
        "surface_half_size": list(surface.half_size),
        "depth_m": shared.DEPTH,
        "other_bodies_touching_at_test": others,
        "ramp_s": shared.RAMP,
        "settle_s": shared.SETTLE,
        "record_s": shared.RECORD,
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
    if shared.touch_site(pair.model) is None:
        return [skipped("contact_stability", "no fingertip force sensor", bound)]
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
    text = table(rows, ["joint", "MAD, centred window [rad]", "mean [rad]", "status"])
    text += (
        f"\nnormal force on {run.setup['fingertip']}: mean {force_mean:.4g} N, std {force_std:.3g} N "
        f"({variation:.3%}); touch sensor mean {touch.mean():.4g} N, std {touch.std():.3g} N"
        f"\nsurface along {np.array2string(np.array(run.setup['direction']), precision=3)}: "
        f"{run.setup['direction_from']}"
    )
    if options.plots is not None:
        from svhdesc.validate.plots import plot_contact

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
        "window_placement": "centred (MATLAB movmean: 5 samples before, 4 after)",
        "setup": run.setup,
        "warnings": run.warnings,
    }
    measured = f"max MAD {fmt(float(deviations.max()))} rad, F {force_mean:.3g} N +- {variation:.2%}"
    detail = "; ".join(problems) or f"{len(joints)} joints still, {run.setup['direction_from']}"
    return [Check("contact_stability", verdict(not problems), measured, bound, detail, figures, table=text)]
