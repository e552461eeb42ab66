"""Run the experiment on one engine x inertia setting, and on the whole grid; compute the metrics."""

from __future__ import annotations

import importlib
import math
import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from svhdesc.compare import experiment
from svhdesc.compare.engine import TIMESTEP, Engine, EngineMissing, RunConfig
from svhdesc.errors import SvhdescError

ENGINES: dict[str, str] = {
    "mujoco": "svhdesc.compare.mujoco_engine:MujocoEngine",
    "dart": "svhdesc.compare.dart_engine:DartEngine",
    "bullet": "svhdesc.compare.bullet_engine:BulletEngine",
    "drake": "svhdesc.compare.drake_engine:DrakeEngine",
    "ode": "svhdesc.compare.ode_engine:OdeEngine",
}
FORCE_WINDOW = 100  # samples in the force's moving mean (plots)
EXPLODED_RAD = 50.0  # rad: a joint this far out has left any physical range
EXPLODED_M = 5.0  # m: a fingertip this far from its test position has left the robot's reach
TIP_TOLERANCE = 0.01  # m: fingertip error up to which the test pose counts as reached
STATUS_OK, STATUS_MISSING, STATUS_BLEW_UP, STATUS_FAILED = "ok", "not installed", "blew up", "failed"


def engine_class(name: str) -> type[Engine]:
    module, _, attr = ENGINES[name].partition(":")
    return getattr(importlib.import_module(module), attr)


def inertia_label(inertia: float | None) -> str:
    return "physical" if inertia is None else f"{inertia:g}"


@dataclass
class Result:
    """One engine x inertia run: metrics, or why there are none."""

    engine: str
    inertia: float | None
    status: str
    note: str = ""
    settings: dict[str, Any] = field(default_factory=dict)
    joints: list[str] = field(default_factory=list)
    actuated: list[str] = field(default_factory=list)
    mad: dict[str, float] = field(default_factory=dict)  # every joint
    mad_average: float = math.nan  # over the actuated joints, as Tables 5.1/5.2 average them
    force_mean: float = math.nan
    force_std: float = math.nan
    contact_share: float = math.nan
    coupling_residual: float = math.nan  # worst over the run [rad]
    worst_coupling: str = ""
    coupling_residual_free: float = math.nan  # worst before the fingertip first touches the surface [rad]
    tip_error: float = math.nan  # m, mean fingertip position while recording vs the test keyframe
    reached: bool = False
    realtime_factor: float = math.nan
    simulated_s: float = 0.0
    failed_at: float | None = None  # s, when the run blew up
    window: str = "centred"  # eq. 5.1's window placement
    force_kind: str = "normal"  # the contact force recorded: along the normal, or its vertical component
    # Time series for the plots (not written to JSON/CSV).
    time: np.ndarray = field(default_factory=lambda: np.zeros(0), repr=False)
    qpos: np.ndarray = field(default_factory=lambda: np.zeros((0, 0)), repr=False)
    force: np.ndarray = field(default_factory=lambda: np.zeros(0), repr=False)
    record_from: int = 0

    @property
    def label(self) -> str:
        return inertia_label(self.inertia)

    def summary(self) -> dict[str, Any]:
        return {
            "engine": self.engine,
            "inertia": self.label,
            "status": self.status,
            "note": self.note,
            "mad_rad": self.mad,
            "mad_window": self.window,
            "force": self.force_kind,
            "mad_average_rad": _finite(self.mad_average),
            "force_mean_n": _finite(self.force_mean),
            "force_std_n": _finite(self.force_std),
            "contact_share": _finite(self.contact_share),
            "coupling_residual_rad": _finite(self.coupling_residual),
            "worst_coupling": self.worst_coupling,
            "coupling_residual_before_contact_rad": _finite(self.coupling_residual_free),
            "tip_error_m": _finite(self.tip_error),
            "test_pose_reached": self.reached,
            "realtime_factor": _finite(self.realtime_factor),
            "simulated_s": self.simulated_s,
            "failed_at_s": self.failed_at,
            "settings": self.settings,
        }


def _finite(value: float) -> float | None:
    return float(value) if math.isfinite(value) else None


def run_one(
    name: str, config: RunConfig, duration: float | None, conditions: experiment.Conditions | None = None
) -> Result:
    """Run one engine; a missing engine, a failed load or an explosion is a result, not an exception."""
    setup = config.setup
    conditions = conditions or experiment.Conditions()
    result = Result(name, config.inertia, STATUS_OK, joints=list(setup.joints), actuated=list(setup.actuated))
    result.window, result.force_kind = conditions.window, conditions.force
    cls = engine_class(name)
    try:
        cls.require()
    except EngineMissing as exc:
        result.status, result.note = STATUS_MISSING, str(exc)
        return result
    engine = cls()
    try:
        engine.load(config)
        result.settings = engine.settings()
        _simulate(engine, config, duration, result, conditions)
    except Exception as exc:  # noqa: BLE001 - an engine that cannot load this model is a result
        result.status, result.note = STATUS_FAILED, f"{type(exc).__name__}: {exc}".strip()[:300]
    finally:
        engine.close()
    return result


def _exploded(q: np.ndarray, tip: np.ndarray, reference: np.ndarray) -> str | None:
    if not (np.isfinite(q).all() and np.isfinite(tip).all()):
        return "NaN"
    if np.abs(q).max() > EXPLODED_RAD:
        return f"a joint at {np.abs(q).max():.3g} rad"
    if np.linalg.norm(tip - reference) > EXPLODED_M:
        return f"fingertip {np.linalg.norm(tip - reference):.3g} m away"
    return None


def _simulate(
    engine: Engine, config: RunConfig, duration: float | None, result: Result, conditions: experiment.Conditions
) -> None:
    setup = config.setup
    dt = engine.timestep
    total, record_from, ramp_s = experiment.schedule(dt, duration)
    every = max(1, int(round(conditions.sample_dt / dt)))
    started = time.perf_counter()
    steps, qpos, force, tips = _step_and_sample(engine, setup, total, ramp_s, every, conditions.force, result)
    wall = time.perf_counter() - started
    count = len(qpos)
    result.simulated_s = steps * dt
    result.realtime_factor = result.simulated_s / wall if wall > 0 else math.inf
    result.time = (np.arange(count) + 1) * every * dt
    result.qpos, result.force = qpos, force
    result.record_from = min(record_from // every, count)
    if count:
        _coupling_residuals(result, setup)
    if result.status == STATUS_OK:
        _record_metrics(result, setup, tips, conditions.window)


def _step_and_sample(
    engine: Engine, setup: experiment.Setup, total: int, ramp_s: float, every: int, force_kind: str, result: Result
) -> tuple[int, np.ndarray, np.ndarray, np.ndarray]:
    """Step the ramp from home to the test pose; every `every` steps sample the joints, the fingertip force and
    position. A blow-up stops the run and is marked in `result`. The steps taken and the samples."""
    dt = engine.timestep
    vertical = force_kind == "vertical"
    samples = total // every
    qpos = np.zeros((samples, len(setup.joints)))
    force, tips = np.zeros(samples), np.zeros((samples, 3))
    count = 0
    step = -1
    for step in range(total):
        try:
            engine.step(experiment.ramp(setup.home_ctrl, setup.test_ctrl, step, dt, ramp_s))
        except Exception as exc:  # noqa: BLE001 - a solver that gives up mid-run has blown up, too
            result.status, result.failed_at = STATUS_BLEW_UP, (step + 1) * dt
            result.note = f"{type(exc).__name__}: {str(exc).strip()[:200]} at t = {(step + 1) * dt:.3f} s"
            break
        if (step + 1) % every:
            continue
        q, tip = engine.joint_positions(), engine.fingertip_position()
        problem = _exploded(q, tip, setup.tip_test_position)
        if problem is not None:
            result.status, result.failed_at = STATUS_BLEW_UP, (step + 1) * dt
            result.note = f"{problem} at t = {(step + 1) * dt:.3f} s"
            break
        if count < samples:
            pressed = float(engine.fingertip_force_vector()[2]) if vertical else engine.fingertip_force()
            qpos[count], force[count], tips[count] = q, pressed, tip
            count += 1
    return step + 1, qpos[:count], force[:count], tips[:count]


def _coupling_residuals(result: Result, setup: experiment.Setup) -> None:
    """The worst coupling residual over the run, and before the fingertip first touches the surface."""
    residual = setup.coupling_residual(result.qpos)
    if not residual.size:
        result.coupling_residual = result.coupling_residual_free = 0.0
        return
    worst = np.unravel_index(int(np.argmax(residual)), residual.shape)
    result.coupling_residual = float(residual[worst])
    result.worst_coupling = setup.couplings[worst[1]].joint
    # Free motion (home -> test before the first touch) shows whether the engine keeps the
    # coupling at all; under the pressing load a soft constraint may also give way.
    touching = np.flatnonzero(result.force != 0)
    free = residual[: touching[0]] if len(touching) else residual
    result.coupling_residual_free = float(free.max()) if len(free) else math.nan


def _record_metrics(result: Result, setup: experiment.Setup, tips: np.ndarray, window: str) -> None:
    """Eq. 5.1's MAD, the force and the fingertip error over the recorded phase (too few samples: failed)."""
    recorded = result.qpos[result.record_from :]
    if len(recorded) < experiment.WINDOW:
        result.status, result.note = STATUS_FAILED, f"only {len(recorded)} samples recorded; run longer"
        return
    deviations = experiment.mad(recorded, placement=window)
    result.mad = {name: float(v) for name, v in zip(setup.joints, deviations, strict=True)}
    result.mad_average = float(np.mean([result.mad[name] for name in setup.actuated]))
    pressed = result.force[result.record_from :]
    result.force_mean, result.force_std = float(pressed.mean()), float(pressed.std())
    result.contact_share = float(np.mean(pressed != 0))
    tip_mean = tips[result.record_from :].mean(axis=0)
    result.tip_error = float(np.linalg.norm(tip_mean - setup.tip_test_position))
    result.reached = result.tip_error <= TIP_TOLERANCE


def run_grid(
    variant: str,
    engines: list[str],
    inertias: list[float | None],
    duration: float | None = None,
    progress: Any = None,
    conditions: experiment.Conditions | None = None,
) -> tuple[experiment.Setup, list[Result]]:
    """Every engine x inertia; ``progress(result)`` is called after each run."""
    if duration is not None and not 0 < duration < math.inf:  # inf failed every run, then exited 0
        raise SvhdescError(f"--duration must be a positive, finite number of seconds, not {duration}")
    from svhdesc.compare.mujoco_engine import finger_links, hand_links, servo
    from svhdesc.model import get

    conditions = conditions or experiment.Conditions()
    built = get(variant)
    mjcf = built.mjcf_path
    setup = experiment.define(mjcf, conditions.test_pose)
    links = finger_links(mjcf, built.hand)
    heavy = hand_links(mjcf, built.hand) if conditions.link_mass is not None else frozenset()
    results = []
    for inertia in inertias:
        gains = servo(mjcf, inertia, links, setup.actuated, conditions.link_mass, heavy)
        config = RunConfig(variant, setup, inertia, links, gains, TIMESTEP, conditions.link_mass, heavy)
        for name in engines:
            result = run_one(name, config, duration, conditions)
            results.append(result)
            if progress is not None:
                progress(result)
    return setup, results
