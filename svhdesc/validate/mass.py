"""Check 5: mass budget, physical inertias, MuJoCo's minimum mass, and URDF/MJCF mass properties that agree."""

from __future__ import annotations

import fnmatch
from typing import Any

import numpy as np

from svhdesc.validate.options import Options
from svhdesc.validate.pair import ModelPair
from svhdesc.validate.report import Check, fmt, not_run, summary, verdict

BUDGET_TOL = 1e-6  # relative: the build splits the budget exactly; this only absorbs summation order
AGREE_TOL = 1e-9  # relative
TRIANGLE_TOL = 1e-9  # relative to the largest principal moment
HAND_PATTERN = "*_hand_*"


def check_mass_budget(pair: ModelPair, options: Options) -> list[Check]:
    if pair.urdf is None:
        return [not_run("mass_budget", f"the URDF cannot be read ({pair.urdf_error})")]
    masses = {name: i.mass for name, i in pair.urdf.links.items() if i is not None}
    configuration = pair.configuration
    if configuration is None:
        hand = sum(m for n, m in masses.items() if fnmatch.fnmatchcase(n, HAND_PATTERN))
        rest = sum(masses.values()) - hand
        # No configuration describes this pair, so there is no budget to hold it to: report the totals.
        return [
            Check(
                "mass_budget",
                "pass",
                f"hand {hand:.4f} kg, other {rest:.4f} kg",
                "none (not configured)",
                "not a configured variant: totals only",
                {"hand_kg": hand, "other_kg": rest},
            )
        ]
    settings = configuration.settings.mass
    prefix = pair.hand.prefix if pair.hand is not None else None  # the built model's, as the build expanded it
    problems, parts, figures = [], [], {}
    for budget in settings.budgets:
        pattern = str(budget["links"]).format(hand=prefix or "")
        total = sum(m for n, m in masses.items() if fnmatch.fnmatchcase(n, pattern))
        target = float(budget["total"])
        figures[pattern] = {"total_kg": total, "budget_kg": target}
        parts.append(f"{pattern} {total:.4f}/{target:g} kg")
        if abs(total - target) > BUDGET_TOL * target:
            problems.append(f"links {pattern} weigh {total:.6g} kg, budget {target:g} kg")
    explicit = {**settings.links, **{k: v["mass"] for k, v in settings.explicit_inertials.items()}}
    present = {name: float(m) for name, m in explicit.items() if name in pair.urdf.links}
    if present:
        got = sum(masses.get(n, 0.0) for n in present)
        want = sum(present.values())
        parts.append(f"configured links {got:.4f}/{want:.4g} kg")
        figures["configured_links"] = {n: {"mass_kg": masses.get(n, 0.0), "config_kg": m} for n, m in present.items()}
        for name, want_mass in present.items():
            if abs(masses.get(name, 0.0) - want_mass) > AGREE_TOL * want_mass:
                problems.append(f"{name} weighs {masses.get(name, 0.0):.6g} kg, config says {want_mass:g} kg")
    detail = (
        "; ".join(problems) or f"bounds from {configuration.config_dir.name}/ config, variant {configuration.variant}"
    )
    return [
        Check(
            "mass_budget",
            verdict(not problems),
            ", ".join(parts) or "-",
            "configured masses",
            detail,
            {"budgets": figures, "problems": problems},
        )
    ]


def _physical(mass: float, moments: np.ndarray) -> str | None:
    """None if the principal moments (sorted) are positive and obey the triangle inequality."""
    if mass <= 0:
        return f"mass {mass:.3g}"
    if moments[0] <= 0:
        return f"not positive definite (principal moments {np.array2string(moments, precision=3)})"
    if moments[0] + moments[1] < moments[2] * (1 - TRIANGLE_TOL):
        return f"violates the triangle inequality ({np.array2string(moments, precision=3)})"
    return None


def check_inertia(pair: ModelPair, options: Options) -> list[Check]:
    bound = "positive definite, A + B >= C"
    problems, count = [], 0
    if pair.urdf is not None:
        for name, inertial in pair.urdf.links.items():
            if inertial is None:
                continue
            count += 1
            moments = np.linalg.eigvalsh(inertial.tensor)
            issue = _physical(inertial.mass, moments)
            if issue:
                problems.append(f"URDF {name}: {issue}")
    if pair.model is not None:
        model = pair.model
        for body in range(1, model.nbody):
            if model.body_mass[body] == 0 and not model.body_inertia[body].any():
                continue  # massless: min_mass decides whether that is allowed
            count += 1
            issue = _physical(float(model.body_mass[body]), np.sort(model.body_inertia[body]))
            if issue:
                problems.append(f"MJCF {model.body(body).name}: {issue}")
    if pair.urdf is None and pair.model is None:
        return [not_run("inertia", "neither file can be read", bound)]
    missing = [w for w, ok in (("URDF", pair.urdf is not None), ("MJCF", pair.model is not None)) if not ok]
    if missing:
        problems.append(f"{' and '.join(missing)} not checked (cannot be read)")
    detail = summary(problems, f"{count} inertials (URDF and compiled MJCF)")
    return [
        Check(
            "inertia", verdict(not problems), f"{len(problems)} bad of {count}", bound, detail, {"problems": problems}
        )
    ]


def check_min_mass(pair: ModelPair, options: Options) -> list[Check]:
    import mujoco

    bound = f"mass, inertia >= mjMINVAL ({mujoco.mjMINVAL:g})"
    if pair.model is None:
        return [not_run("min_mass", "the MJCF does not compile", bound)]
    model = pair.model
    problems, static_massless = [], []
    for body in range(1, model.nbody):
        mass, inertia = float(model.body_mass[body]), model.body_inertia[body]
        if mass >= mujoco.mjMINVAL and inertia.min() >= mujoco.mjMINVAL:
            continue
        name = model.body(body).name
        if mass == 0 and not inertia.any() and model.body_jntnum[body] == 0:
            static_massless.append(name)  # welded to its parent: MuJoCo needs no mass there
            continue
        problems.append(f"{name}: mass {mass:.3g} kg, inertia {np.array2string(inertia, precision=3)}")
    lightest = min((float(model.body_mass[b]) for b in range(1, model.nbody) if model.body_mass[b] > 0), default=0.0)
    detail = (
        "; ".join(problems)
        or f"lightest body {lightest:.3g} kg; {len(static_massless)} massless static "
        f"bodies ({', '.join(static_massless[:5])}{', ...' if len(static_massless) > 5 else ''})"
    )
    return [
        Check(
            "min_mass",
            verdict(not problems),
            f"{len(problems)} below",
            bound,
            detail,
            {"below": problems, "massless_static": static_massless, "lightest_kg": lightest},
        )
    ]


def mjcf_tensor(model: Any, body: int) -> np.ndarray:
    """The compiled inertia back in the body frame: R diag(I) R^T with R from body_iquat."""
    import mujoco

    rotation = np.zeros(9)
    mujoco.mju_quat2Mat(rotation, model.body_iquat[body])
    rotation = rotation.reshape(3, 3)
    return rotation @ np.diag(model.body_inertia[body]) @ rotation.T


def check_mass_agreement(pair: ModelPair, options: Options) -> list[Check]:
    bound = f"relative <= {AGREE_TOL:g}"
    if pair.model is None or pair.urdf is None:
        return [not_run("mass_agreement", "needs both files", bound)]
    model = pair.model
    problems, worst, compared = [], 0.0, 0
    bodies = _body_names(model)
    for name, inertial in pair.urdf.links.items():
        body = model.body(name).id if name in bodies else -1
        if body <= 0:
            continue  # the world link, or a link kinematics reports as missing
        compared += 1
        mj_mass = float(model.body_mass[body])
        if inertial is None:
            if mj_mass != 0:
                problems.append(f"{name}: no URDF inertial, MJCF mass {mj_mass:.6g} kg")
            continue
        errors = {
            "mass": abs(inertial.mass - mj_mass) / max(abs(inertial.mass), 1e-300),
            # COM and tensor relative to their own size; 1 mm floor for a COM at the frame origin.
            "com": float(np.linalg.norm(inertial.com - model.body_ipos[body]))
            / max(float(np.linalg.norm(inertial.com)), 1e-3),
            "inertia": float(np.linalg.norm(inertial.tensor - mjcf_tensor(model, body)))
            / max(float(np.linalg.norm(inertial.tensor)), 1e-300),
        }
        worst = max(worst, *errors.values())
        bad = [f"{k} {v:.2g}" for k, v in errors.items() if v > AGREE_TOL]
        if bad:
            problems.append(f"{name}: {', '.join(bad)}")
    detail = summary(problems, f"{compared} links: mass, COM and inertia tensor")
    return [
        Check(
            "mass_agreement",
            verdict(not problems),
            f"{fmt(worst)} relative",
            bound,
            detail,
            {"compared": compared, "max_relative_error": worst, "problems": problems},
        )
    ]


def _body_names(model: Any) -> set[str]:
    return {model.body(b).name for b in range(model.nbody)}
