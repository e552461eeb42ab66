"""Poses of a compiled robot file: its rest pose and a Halton sequence over its joints' ranges, the same on any
machine (no random generator), shared by the full tier's compile step and its checks."""

from __future__ import annotations

import math

import numpy as np

from svhdesc.core.halton import halton


def joint_ranges(model) -> tuple[np.ndarray, np.ndarray, np.ndarray]:  # type: ignore[no-untyped-def]
    """The 1-dof joints (hinge, slide) and their ranges; an unlimited hinge spans one turn."""
    joints = np.flatnonzero(np.isin(model.jnt_type, (2, 3)))
    lo = np.where(model.jnt_limited[joints], model.jnt_range[joints, 0], -math.pi)
    hi = np.where(model.jnt_limited[joints], model.jnt_range[joints, 1], math.pi)
    return joints, lo, hi


def set_pose(model, data, sample: int) -> None:  # type: ignore[no-untyped-def]
    """Halton point ``sample`` (from 1) of the joints' ranges into data.qpos; other coordinates stay."""
    joints, lo, hi = joint_ranges(model)
    data.qpos[model.jnt_qposadr[joints]] = lo + (hi - lo) * halton(sample, joints.size)


def rest_state(model, key: int = 0):  # type: ignore[no-untyped-def]
    """Keyframe ``key``'s qpos and ctrl (the settings' keyframe, else 0), else qpos0 within the limits with every
    position servo aimed at its joint."""
    import mujoco

    data = mujoco.MjData(model)
    if model.nkey:
        mujoco.mj_resetDataKeyframe(model, data, key)
        return data, f"keyframe '{model.key(key).name or key}'"
    joints, lo, hi = joint_ranges(model)
    addresses = model.jnt_qposadr[joints]
    data.qpos[addresses] = np.clip(data.qpos[addresses], lo, hi)
    for i in range(model.nu):
        if is_position_servo(model, i):
            data.ctrl[i] = data.qpos[model.jnt_qposadr[model.actuator_trnid[i, 0]]]
    return data, "the rest pose"


def is_position_servo(model, actuator: int) -> bool:  # type: ignore[no-untyped-def]
    """A position servo on one joint: force kp (ctrl - q) - kv qdot, as <position> and init's servos write it."""
    import mujoco

    gain = model.actuator_gainprm[actuator, 0]
    return bool(
        model.actuator_trntype[actuator] == mujoco.mjtTrn.mjTRN_JOINT
        and model.actuator_biastype[actuator] == mujoco.mjtBias.mjBIAS_AFFINE
        and gain > 0
        and gain == -model.actuator_biasprm[actuator, 1]
    )


def contact_pairs(model, data) -> dict[tuple[str, str], float]:  # type: ignore[no-untyped-def]
    """Each pair of bodies in contact in data's pose and its deepest penetration (m, > 0). A body touching its
    parent is left out, whatever the parent: MuJoCo filters those pairs except where the parent is welded to the
    world, which a gripper's palm is only while the file is loaded on its own."""
    import mujoco

    mujoco.mj_forward(model, data)
    pairs: dict[tuple[str, str], float] = {}
    for contact in data.contact[: data.ncon]:
        first, second = (int(model.geom_bodyid[g]) for g in contact.geom)
        if first == model.body_parentid[second] or second == model.body_parentid[first]:
            continue
        a, b = sorted(model.body(body).name or "world" for body in (first, second))
        pairs[(a, b)] = max(pairs.get((a, b), 0.0), -float(contact.dist))
    return pairs


def always_touching(model, samples: int) -> dict[tuple[str, str], float]:  # type: ignore[no-untyped-def]
    """The pairs of bodies in contact in the rest pose and in every one of ``samples`` Halton poses, each with its
    least penetration: geometry that overlaps whatever the joints do."""
    data, _ = rest_state(model)
    always = contact_pairs(model, data)
    for sample in range(1, samples + 1):
        set_pose(model, data, sample)
        seen = contact_pairs(model, data)
        always = {pair: min(depth, seen[pair]) for pair, depth in always.items() if pair in seen}
    return always
