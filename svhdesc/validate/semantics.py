"""The build's semantic rules, checked again on the files: a hand-edited or foreign model must meet them too.

Positive timestep; actuators with ordered commands, a force range around zero and gains >= 0; every
movable joint driven (an actuator or a joint equality to one); URDF effort and velocity > 0 on
movable joints; ordered limits; keyframes within them.
"""

from __future__ import annotations

import math
from typing import Any

from lxml import etree

from svhdesc.validate.options import Options
from svhdesc.validate.pair import ModelPair, joint_equalities
from svhdesc.validate.report import Check, not_run, summary, verdict

LIMIT_TOL = 1e-9


def _mjcf_problems(m: Any) -> list[str]:  # m: mujoco.MjModel
    problems = []
    if not m.opt.timestep > 0:
        problems.append(f"timestep {m.opt.timestep:g} must be > 0")
    problems += _actuator_problems(m)
    joint_problems, limited = _joint_problems(m)
    return problems + joint_problems + _keyframe_problems(m, limited)


def _driven_joints(m: Any) -> set[int]:
    """The joints an actuator drives directly."""
    import mujoco

    joint_kinds = {int(mujoco.mjtTrn.mjTRN_JOINT), int(mujoco.mjtTrn.mjTRN_JOINTINPARENT)}
    return {int(m.actuator_trnid[i, 0]) for i in range(m.nu) if int(m.actuator_trntype[i]) in joint_kinds}


def _actuator_problems(m: Any) -> list[str]:
    """Ordered commands, a force range holding zero strictly inside, gains >= 0."""
    problems = []
    for i in range(m.nu):
        name = m.actuator(i).name
        # With autolimits an inverted range silently turns the limit off: read the numbers themselves.
        low, high = m.actuator_ctrlrange[i]
        if (m.actuator_ctrllimited[i] or low or high) and not low < high:
            problems.append(f"actuator {name}: ctrlrange [{low:g}, {high:g}] is not ordered")
        low, high = m.actuator_forcerange[i]
        if not (m.actuator_forcelimited[i] and low < 0 < high):
            problems.append(f"actuator {name}: forcerange [{low:g}, {high:g}] must hold zero strictly inside")
        if m.actuator_gainprm[i, 0] < 0:
            problems.append(f"actuator {name}: gain {m.actuator_gainprm[i, 0]:g} must be >= 0")
    return problems


def _joint_problems(m: Any) -> tuple[list[str], dict[int, tuple[float, float]]]:
    """Every hinge and slide driven (an actuator or a joint equality) with ordered limits; and the limited ones'
    ranges."""
    import mujoco

    problems = []
    driven = _driven_joints(m)
    coupled = {eq.joint for eq in joint_equalities(m)}
    limited: dict[int, tuple[float, float]] = {}
    for j in range(m.njnt):
        joint = m.joint(j)
        if int(m.jnt_type[j]) not in (int(mujoco.mjtJoint.mjJNT_HINGE), int(mujoco.mjtJoint.mjJNT_SLIDE)):
            continue
        if j not in driven and joint.name not in coupled:
            problems.append(f"joint {joint.name}: nothing drives it (no actuator, no joint equality)")
        if m.jnt_limited[j]:
            low, high = (float(v) for v in m.jnt_range[j])
            if not low <= high:
                problems.append(f"joint {joint.name}: range [{low:g}, {high:g}] is not ordered")
            limited[j] = (low, high)
    return problems, limited


def _keyframe_problems(m: Any, limited: dict[int, tuple[float, float]]) -> list[str]:
    """Every keyframe within the limited joints' ranges."""
    problems = []
    for k in range(m.nkey):
        for j, (low, high) in limited.items():
            value = float(m.key_qpos[k, m.jnt_qposadr[j]])
            if not low - LIMIT_TOL <= value <= high + LIMIT_TOL:
                problems.append(
                    f"keyframe {m.key(k).name}: {m.joint(j).name} at {value:.6g} outside [{low:g}, {high:g}]"
                )
    return problems


def _urdf_problems(pair: ModelPair) -> list[str]:
    problems = []
    root = etree.parse(str(pair.urdf_path), etree.XMLParser(resolve_entities=False, no_network=True)).getroot()
    for joint in root.findall("joint"):
        if joint.get("type") not in {"revolute", "prismatic", "continuous"}:
            continue
        limit = joint.find("limit")
        for key in ("effort", "velocity"):
            try:
                value = float(limit.get(key, "0")) if limit is not None else 0.0
            except ValueError:
                value = math.nan
            if not value > 0:
                problems.append(f"URDF joint {joint.get('name')}: {key} {value:g} must be > 0")
        if limit is not None and joint.get("type") != "continuous":
            try:
                low, high = float(limit.get("lower", "0")), float(limit.get("upper", "0"))
            except ValueError:
                low, high = math.nan, math.nan
            if not low <= high:
                problems.append(f"URDF joint {joint.get('name')}: limit [{low:g}, {high:g}] is not ordered")
    return problems


def check_semantics(pair: ModelPair, options: Options) -> list[Check]:
    bound = "every movable joint driven; effort, velocity, timestep > 0; gains >= 0; keyframes in limits"
    if pair.model is None or pair.urdf is None:
        return [not_run("semantics", "needs both files", bound)]
    problems = _mjcf_problems(pair.model) + _urdf_problems(pair)
    return [
        Check(
            "semantics",
            verdict(not problems),
            f"{len(problems)} problem(s)",
            bound,
            summary(problems, "all rules hold"),
            {"problems": problems},
        )
    ]
