"""Check 8, the thesis experiment: the index fingertip presses a fixed surface; joints must stay still.

The robot is driven from keyframe ``home`` to ``test`` by its position actuators (control ramped over
RAMP s). A static box is added so that its face sits DEPTH inside the fingertip's collision geometry
in the ``test`` pose; the servos then press the tip into it. After SETTLE s, joint positions and the
fingertip's normal force are recorded for RECORD s. Per joint, the mean absolute deviation from the
running average of the WINDOW samples around it (thesis eq. 5.1, centred) must stay below MAD_BOUND; the force
must be positive and steady. What holds the contact is reported beside the force (svhdesc.validate.stops): on a
finger the surface pushes into its joint limits, the force measures the stops, not the servos. The experiment
itself (surface placement, ramp, schedule, eq. 5.1) is defined in ``svhdesc.compare.experiment``, shared with
``svhdesc compare``.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from svhdesc.compare import experiment as shared
from svhdesc.model import scalar_joints
from svhdesc.validate.options import Options
from svhdesc.validate.pair import ModelPair
from svhdesc.validate.report import Check, fmt, not_run, skipped, table, verdict
from svhdesc.validate.stops import Load, load

MAD_BOUND = 1e-9  # rad
FORCE_CV_BOUND = 0.02  # std / mean of the normal force

__all__ = ["Experiment", "check_contact_stability", "run_experiment"]


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
    load: Load | None = None  # what holds the contact at the last step: the servos or the joint stops


def run_experiment(pair: ModelPair) -> Experiment:
    import mujoco

    from svhdesc.model import warning_counts

    model = pair.model
    home, test = shared.keyframes(model)
    tip, _ = shared.fingertip(model)
    surface = shared.place_surface(model)

    spec = mujoco.MjSpec.from_file(str(pair.mjcf_path))
    shared.add_surface(spec, surface)
    scene = spec.compile()
    box = mujoco.mj_name2id(scene, mujoco.mjtObj.mjOBJ_GEOM, shared.SURFACE)
    sdata = mujoco.MjData(scene)

    mujoco.mj_resetDataKeyframe(scene, sdata, test)
    mujoco.mj_forward(scene, sdata)
    others = sorted(shared.bodies_touching(scene, sdata, box) - {scene.body(tip).name})

    mujoco.mj_resetDataKeyframe(scene, sdata, home)
    dt = scene.opt.timestep
    _, record_from, _ = shared.schedule(dt)
    joints = scalar_joints(scene)
    press = _Press(scene, sdata, box, tip, {int(g) for g in range(scene.ngeom) if scene.geom_bodyid[g] == tip})
    qpos, force, touch, nan_at = press.record(scene.key_ctrl[home].copy(), scene.key_ctrl[test].copy(), joints)
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
        load(scene, sdata, tip, press.tip_contacts()) if nan_at is None else None,
    )


@dataclass
class _Press:
    """The model with the surface, pressing the fingertip (its geoms) into the surface's box."""

    scene: Any
    data: Any
    box: int
    tip: int  # the fingertip's body
    tip_geoms: set[int]

    def record(
        self, start: np.ndarray, goal: np.ndarray, joints: list[int]
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, float | None]:
        """Ramp the controls from start to goal and hold: the joints, the tip's normal force and the touch sensor
        each step (cut short where the state turns NaN, and when)."""
        import mujoco

        scene, sdata = self.scene, self.data
        dt = scene.opt.timestep
        total, _, _ = shared.schedule(dt)
        addresses = scene.jnt_qposadr[joints]
        touch_adr = next(
            int(scene.sensor_adr[s])
            for s in range(scene.nsensor)
            if int(scene.sensor_type[s]) == int(mujoco.mjtSensor.mjSENS_TOUCH)
        )
        qpos = np.zeros((total, len(joints)))
        force, touch = np.zeros(total), np.zeros(total)
        for step in range(total):
            sdata.ctrl[:] = shared.ramp(start, goal, step, dt)
            mujoco.mj_step(scene, sdata)
            if not np.isfinite(sdata.qpos).all():
                return qpos[:step], force[:step], touch[:step], step * dt
            qpos[step] = sdata.qpos[addresses]
            force[step] = self.normal_force()
            touch[step] = sdata.sensordata[touch_adr]
        return qpos, force, touch, None

    def tip_contacts(self) -> list[int]:
        """Indices of the box's contacts with the fingertip (on the contact list's columns: a Python object per
        contact and step cost about 1.5 s of the check's 5)."""
        contacts, tips = self.data.contact, list(self.tip_geoms)
        first, second = contacts.geom1, contacts.geom2
        touching = ((first == self.box) & np.isin(second, tips)) | ((second == self.box) & np.isin(first, tips))
        return [int(i) for i in np.flatnonzero(touching)]

    def normal_force(self) -> float:
        """The normal force of the box's contacts with the fingertip."""
        import mujoco

        wrench = np.zeros(6)
        normal_force = 0.0
        for index in self.tip_contacts():
            mujoco.mj_contactForce(self.scene, self.data, index, wrench)
            normal_force += wrench[0]
        return normal_force


def check_contact_stability(pair: ModelPair, options: Options) -> list[Check]:
    bound = f"MAD <= {MAD_BOUND:g} rad, F > 0, std/F <= {FORCE_CV_BOUND:.0%}"
    if pair.model is None:
        return [not_run("contact_stability", "the MJCF does not compile", bound)]
    if shared.touch_site(pair.model) is None:
        return [skipped("contact_stability", "no fingertip force sensor", bound)]
    try:
        run = run_experiment(pair)
    except shared.SetupError as exc:
        return [not_run("contact_stability", str(exc), bound)]
    if run.nan_at is not None:
        return [
            Check("contact_stability", "fail", "NaN", bound, f"NaN at t = {run.nan_at:.3f} s", {"setup": run.setup})
        ]
    recorded = run.qpos[run.record_from :]
    deviations = shared.mad(recorded)
    means = recorded.mean(axis=0)
    force = _Force(run.force[run.record_from :])
    touch = run.touch[run.record_from :]
    joints = {
        name: {"mad_rad": float(m), "mean_rad": float(x), "pass": bool(m <= MAD_BOUND)}
        for name, m, x in zip(run.joints, deviations, means, strict=True)
    }
    problems = _problems(run, joints, deviations, force)
    text = _table(run, joints, force, touch)
    if options.plots is not None:
        from svhdesc.validate.plots import plot_contact

        run.setup["plots"] = [str(p) for p in plot_contact(run, pair.name, pair.hand, options.plots)]
    figures = {
        "joints": joints,
        "force_mean_n": force.mean,
        "force_std_n": force.std,
        "force_variation": force.variation,
        "touch_mean_n": float(touch.mean()),
        "touch_std_n": float(touch.std()),
        "samples": int(len(force.samples)),
        "window": shared.WINDOW,
        "window_placement": "centred (MATLAB movmean: 5 samples before, 4 after)",
        "setup": run.setup,
        "warnings": run.warnings,
        **_load_figures(run.load),
    }
    measured = f"max MAD {fmt(float(deviations.max()))} rad, F {force.mean:.3g} N +- {force.variation:.2%}"
    if run.load is not None and run.load.held_by_stops:
        measured += f", {run.load.stop_share:.0%} on joint stops"
    still = f"{len(joints)} joints still, {run.setup['direction_from']}"
    detail = "; ".join([*problems, *([run.load.describe()] if run.load is not None else [])]) or still
    return [Check("contact_stability", verdict(not problems), measured, bound, detail, figures, table=text)]


def _load_figures(held: Load | None) -> dict[str, Any]:
    if held is None:
        return {}
    return {
        "held_by": "joint stops" if held.held_by_stops else "servos",
        "stop_share": held.stop_share,
        "contact_load_on_joints": held.contact,
        "joint_stop_load": held.stops,
    }


class _Force:
    """The recorded normal force: mean, standard deviation, and their ratio (inf without a positive mean)."""

    def __init__(self, samples: np.ndarray) -> None:
        self.samples = samples
        self.mean, self.std = float(samples.mean()), float(samples.std())
        self.variation = self.std / self.mean if self.mean > 0 else float("inf")


def _problems(run: Experiment, joints: dict[str, dict], deviations: np.ndarray, force: _Force) -> list[str]:
    """Joints above the MAD bound, an absent or unsteady force, MuJoCo warnings, other bodies on the surface."""
    moving = [n for n, v in joints.items() if not v["pass"]]
    problems = []
    if moving:
        problems.append(
            f"{len(moving)} of {len(joints)} joints above the MAD bound (worst "
            f"{run.joints[int(np.argmax(deviations))]} {deviations.max():.3g} rad)"
        )
    if force.mean <= 0:
        problems.append("no normal force on the fingertip: it does not reach the surface")
    elif force.variation > FORCE_CV_BOUND:
        problems.append(f"normal force varies {force.variation:.2%} (std {force.std:.3g} N)")
    if run.warnings:
        problems.append("MuJoCo warnings " + ", ".join(f"{k} x{v}" for k, v in run.warnings.items()))
    if run.setup["other_bodies_touching_at_test"]:
        problems.append(
            f"the surface also touches {', '.join(run.setup['other_bodies_touching_at_test'])} in the test pose"
        )
    return problems


def _table(run: Experiment, joints: dict[str, dict], force: _Force, touch: np.ndarray) -> str:
    """Each joint's MAD and mean, then the force, the touch sensor and where the surface faces."""
    rows = [
        [name, f"{v['mad_rad']:.3e}", f"{v['mean_rad']:+.6f}", "pass" if v["pass"] else "FAIL"]
        for name, v in joints.items()
    ]
    text = table(rows, ["joint", "MAD, centred window [rad]", "mean [rad]", "status"])
    return text + (
        f"\nnormal force on {run.setup['fingertip']}: mean {force.mean:.4g} N, std {force.std:.3g} N "
        f"({force.variation:.3%}); touch sensor mean {touch.mean():.4g} N, std {touch.std():.3g} N"
        f"\nsurface along {np.array2string(np.array(run.setup['direction']), precision=3)}: "
        f"{run.setup['direction_from']}" + (f"\n{run.load.describe()}" if run.load is not None else "")
    )
