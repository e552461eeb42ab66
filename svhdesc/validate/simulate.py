"""Checks 1 and 2a: the MJCF survives random position targets; coupled joints track their polynomial."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from svhdesc.model import RANDOM_TARGET_SECONDS, couplings, run_random_targets
from svhdesc.model import random_target_start as start
from svhdesc.validate.options import Options
from svhdesc.validate.pair import ModelPair
from svhdesc.validate.report import FAIL, Check, fmt, not_run, skipped, verdict

COUPLING_TOL = 1e-3  # rad


def random_target_start(model: Any, seed: int) -> tuple[Any, np.random.Generator, np.ndarray, np.ndarray]:
    """Data at the `home` keyframe, the seeded generator, and each actuator's target range (unit if unlimited)."""
    data, low, high = start(model)
    return data, np.random.default_rng(seed), low, high


def check_simulation(pair: ModelPair, options: Options) -> list[Check]:
    """Random targets uniformly across each actuator's ctrlrange, a new one every 0.05 s, from a seeded RNG: the
    run the build steps every model through with seed 0 (``svhdesc.model.run_random_targets``)."""
    sim_bound, coupling_bound = "compiles, 0 warnings, no NaN", f"<= {COUPLING_TOL:g} rad"
    if pair.model is None:
        return [
            Check("simulate", FAIL, "does not compile", sim_bound, pair.mjcf_error or ""),
            not_run("coupling_tracking", "the MJCF does not compile", coupling_bound),
        ]
    model = pair.model
    tracking = _Tracking.of(model, couplings(model))
    run = run_random_targets(model, options.seed, tracking.update if len(tracking.equalities) else None)
    warnings, nan_at, diverged = run.warnings, run.nan_at, run.diverged
    ok = not warnings and nan_at is None
    detail = []
    if warnings:
        detail.append("warnings " + ", ".join(f"{k} x{v}" for k, v in warnings.items()))
    if diverged is not None:
        detail.append(str(diverged))
    if nan_at is not None:
        detail.append(f"NaN at t = {nan_at:.3f} s")
    measured = f"{sum(warnings.values())} warnings, {'NaN' if nan_at is not None else 'no NaN'}"
    summary = f"{RANDOM_TARGET_SECONDS:g} s at dt {model.opt.timestep:g} s, {model.nu} actuators"
    checks = [
        Check(
            "simulate",
            verdict(ok),
            measured,
            sim_bound,
            "; ".join(detail) or summary,
            {
                "warnings": warnings,
                "nan_at_s": nan_at,
                "diverged": None if diverged is None else {"t": diverged.time, "joint": diverged.joint},
                "simulated_s": RANDOM_TARGET_SECONDS,
                "timestep": model.opt.timestep,
                "seed": options.seed,
            },
        )
    ]
    if not tracking.equalities:
        checks.append(skipped("coupling_tracking", "no couplings", coupling_bound))
        return checks
    checks.append(_coupling_check(tracking, nan_at, coupling_bound))
    return checks


@dataclass
class _Tracking:
    """Each coupled joint's worst distance from its polynomial of its channel (Horner over padded coefficients)."""

    equalities: list[Any]  # svhdesc.model.Coupling
    coupled: np.ndarray  # qpos addresses of the coupled joints
    leaders: np.ndarray  # and of their channels
    coeffs: np.ndarray  # equalities x 5
    worst: np.ndarray

    @classmethod
    def of(cls, model: Any, equalities: list[Any]) -> _Tracking:
        coupled = np.array([model.jnt_qposadr[model.joint(e.joint).id] for e in equalities], dtype=int)
        leaders = np.array([model.jnt_qposadr[model.joint(e.leader).id] for e in equalities], dtype=int)
        coeffs = np.zeros((len(equalities), 5))
        for i, e in enumerate(equalities):
            coeffs[i, : len(e.coeffs)] = e.coeffs
        return cls(equalities, coupled, leaders, coeffs, np.zeros(len(equalities)))

    def update(self, data: Any) -> None:
        q = data.qpos[self.leaders]
        expected = self.coeffs[:, 4].copy()
        for k in (3, 2, 1, 0):  # Horner
            expected = expected * q + self.coeffs[:, k]
        np.maximum(self.worst, np.abs(data.qpos[self.coupled] - expected), out=self.worst)


def _coupling_check(tracking: _Tracking, nan_at: float | None, bound: str) -> Check:
    errors = {e.joint: float(w) for e, w in zip(tracking.equalities, tracking.worst, strict=True)}
    worst_joint = max(errors, key=errors.get)  # type: ignore[arg-type]
    bad = {k: v for k, v in errors.items() if v > COUPLING_TOL}
    detail_text = (
        f"beyond the bound: {', '.join(f'{k} {v:.3g}' for k, v in bad.items())}" if bad else f"worst {worst_joint}"
    )
    if nan_at is not None:
        detail_text += f" (run stopped at NaN, t = {nan_at:.3f} s)"
    return Check(
        "coupling_tracking",
        verdict(not bad and nan_at is None),
        f"{fmt(errors[worst_joint])} rad",
        bound,
        detail_text,
        {"max_error_rad": errors},
    )
