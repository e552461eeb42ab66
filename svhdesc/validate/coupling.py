"""Checks 2b and 6: URDF mimic and MJCF equality state the same polynomial; coupled limits hold its image."""

from __future__ import annotations

from typing import Any

from svhdesc.model import Coupling, actuated_joints, couplings
from svhdesc.polynomial import image, linearise
from svhdesc.validate.options import Options
from svhdesc.validate.pair import ModelPair
from svhdesc.validate.report import Check, fmt, not_run, skipped, verdict

SPEC_TOL = 1e-9
LIMIT_TOL = 1e-9


def _needs_both(pair: ModelPair, name: str, bound: str) -> Check | None:
    if pair.model is None:
        return not_run(name, "the MJCF does not compile", bound)
    if pair.urdf is None:
        return not_run(name, f"the URDF cannot be read ({pair.urdf_error})", bound)
    return None


def channel_range(model: Any, channel: str) -> tuple[float, float]:
    """The commanded range (actuator ctrlrange) of a channel, else its MJCF joint range."""
    actuated = actuated_joints(model)
    if channel in actuated:
        return actuated[channel]
    low, high = model.jnt_range[model.joint(channel).id]
    return float(low), float(high)


def check_coupling_spec(pair: ModelPair, options: Options) -> list[Check]:
    bound = f"|d offset|, |d multiplier| <= {SPEC_TOL:g}"
    missing = _needs_both(pair, "coupling_spec", bound)
    if missing:
        return [missing]
    assert pair.urdf is not None
    equalities = couplings(pair.model)
    mimics = {j.name: j.mimic for j in pair.urdf.joints.values() if j.mimic is not None}
    if not equalities and not mimics:
        return [skipped("coupling_spec", "no couplings", bound)]
    problems, notes, worst, figures = [], [], 0.0, {}
    for eq in equalities:
        mimic = mimics.get(eq.joint)
        if mimic is None:
            problems.append(f"{eq.joint}: MJCF equality {eq.name} but no URDF <mimic>")
            continue
        if mimic.leader != eq.leader:
            problems.append(f"{eq.joint}: URDF mimics {mimic.leader}, MJCF couples it to {eq.leader}")
            continue
        expected, note = _expected_line(pair.model, eq)
        if note:
            notes.append(note)
        error = max(abs(mimic.offset - expected[0]), abs(mimic.multiplier - expected[1]))
        figures[eq.joint] = {
            "mjcf_polycoef": list(eq.coeffs),
            "urdf_offset": mimic.offset,
            "urdf_multiplier": mimic.multiplier,
            "expected_offset": expected[0],
            "expected_multiplier": expected[1],
            "error": error,
        }
        worst = max(worst, error)
        if error > SPEC_TOL:
            problems.append(
                f"{eq.joint}: URDF offset {mimic.offset:.9g} multiplier {mimic.multiplier:.9g}, MJCF polynomial "
                f"gives offset {expected[0]:.9g} multiplier {expected[1]:.9g}"
            )
        plugin = pair.urdf.mimic_plugins.get(eq.joint)
        if plugin is not None and not _same_mimic(plugin, mimic):
            problems.append(
                f"{eq.joint}: Gazebo mimic plugin ({plugin.leader} x{plugin.multiplier:.9g} "
                f"+{plugin.offset:.9g}) differs from the URDF <mimic>"
            )
    coupled = {eq.joint for eq in equalities}
    for joint in sorted(set(mimics) - coupled):
        problems.append(f"{joint}: URDF <mimic> of {mimics[joint].leader} but no MJCF joint equality")
    detail = "; ".join(problems + notes) or f"{len(equalities)} couplings agree"
    return [
        Check(
            "coupling_spec",
            verdict(not problems),
            f"{fmt(worst)} ({len(equalities)} couplings)",
            bound,
            detail,
            {"couplings": figures, "problems": problems},
        )
    ]


def _expected_line(model: Any, eq: Any) -> tuple[tuple[float, float], str | None]:
    """(offset, multiplier) the URDF <mimic> must carry for the equality; and a note where it is only the
    polynomial's least-squares line (URDF <mimic> is linear; the build writes that line over the channel range)."""
    if any(c != 0.0 for c in eq.coeffs[2:]):
        low, high = channel_range(model, eq.leader)
        note = f"{eq.joint}: polynomial of order > 1; the URDF carries its least-squares line over [{low:g}, {high:g}]"
        return linearise(eq.coeffs, low, high), note
    return (eq.coeffs[0], eq.coeffs[1]), None


def _same_mimic(plugin: Coupling, mimic: Coupling) -> bool:
    """A Gazebo mimic plugin and a URDF <mimic> state the same coupling."""
    error = max(abs(plugin.multiplier - mimic.multiplier), abs(plugin.offset - mimic.offset))
    return plugin.leader == mimic.leader and not error > SPEC_TOL


def check_limits(pair: ModelPair, options: Options) -> list[Check]:
    bound = "image of channel range within limit"
    missing = _needs_both(pair, "limits", bound)
    if missing:
        return [missing]
    assert pair.urdf is not None
    model = pair.model
    if not couplings(model):
        return [skipped("limits", "no couplings", bound)]
    problems, worst, figures = [], 0.0, {}
    for eq in couplings(model):
        low, high = channel_range(model, eq.leader)
        img_low, img_high = image(eq.coeffs, low, high)
        limits = {}
        joint_id = model.joint(eq.joint).id
        if model.jnt_limited[joint_id]:
            limits["MJCF range"] = tuple(float(v) for v in model.jnt_range[joint_id])
        urdf_joint = pair.urdf.joints.get(eq.joint)
        if urdf_joint is not None and urdf_joint.lower is not None:
            limits["URDF limit"] = (urdf_joint.lower, urdf_joint.upper)
        figures[eq.joint] = {
            "channel": eq.leader,
            "channel_range": [low, high],
            "image": [img_low, img_high],
            **{k.replace(" ", "_"): list(v) for k, v in limits.items()},
        }
        for where, (lower, upper) in limits.items():
            excess = max(lower - img_low, img_high - upper, 0.0)
            worst = max(worst, excess)
            if excess > LIMIT_TOL:
                problems.append(
                    f"{eq.joint}: {where} [{lower:.6g}, {upper:.6g}] cannot hold [{img_low:.6g}, "
                    f"{img_high:.6g}], the image of {eq.leader} [{low:.6g}, {high:.6g}]"
                )
    detail = "; ".join(problems) or f"{len(figures)} coupled joints"
    return [
        Check(
            "limits",
            verdict(not problems),
            f"{fmt(worst)} rad excess",
            bound,
            detail,
            {"joints": figures, "problems": problems},
        )
    ]
