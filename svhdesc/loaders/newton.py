"""Load a built variant into Newton (``newton.ModelBuilder``) from its USD, MJCF or URDF, couplings kept.

    model = load_newton("svh_right")                          # the USD layer (NewtonMimicAPI): 11 joint mimics
    model = load_newton("svh_right", "mjcf")                  # MuJoCo's joint equalities, as joint mimics
    model = load_newton("svh_right", "urdf", armature={...})  # <mimic>; the URDF has no armature

Newton's quirks (1.8): its MJCF importer turns a joint equality into a sparse mimic constraint (with the MuJoCo
equality kept for SolverMuJoCo) that SolverFeatherstone and SolverXPBD ignore, so ``load_newton`` moves each onto
the follower joint (``set_joint_mimic``), which Featherstone reduces exactly; the USD and the URDF give joint mimics
already. SolverFeatherstone applies the drives' gains but not their effort limit (run the servo as joint torques to
keep MuJoCo's force range: ``svhdesc.loaders.track``). The URDF carries no armature: without one (``armature``,
kg m^2 per joint name) Featherstone's explicit step diverges on the hand's light distal links.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from svhdesc.loaders._common import absolute_urdf, require
from svhdesc.model import get

FILES = ("usd", "mjcf", "urdf")


def model_file(variant: str, file: str) -> str:
    """The path of the variant's ``file`` ("usd", "mjcf" or "urdf": absolute mesh paths) Newton reads."""
    model = get(variant)
    paths = {"usd": model.usd_path, "mjcf": model.mjcf_path}
    if file not in FILES:
        raise ValueError(f"file must be one of {', '.join(FILES)}, not {file!r}")
    return str(paths[file] if file in paths else absolute_urdf(variant))


def builder_for(
    path: str, file: str, armature: Mapping[str, float] | None = None, gravity: float = -9.81, promote: bool = True
) -> Any:
    """A ``newton.ModelBuilder`` with the model in ``path`` added; ``promote``: the MJCF's couplings as joint mimics
    (for Newton's own solvers; SolverMuJoCo reads the equalities the importer keeps)."""
    newton = require("newton", "load_newton")
    builder = newton.ModelBuilder(gravity=(0.0, 0.0, gravity))
    if file == "usd":
        builder.add_usd(path)
    elif file == "mjcf":
        builder.add_mjcf(path)
        if promote:
            promote_mimics(builder)
    else:
        builder.add_urdf(path, floating=False)
    if armature:
        names = joint_names(builder.joint_label)
        for joint, value in armature.items():
            if joint in names:
                builder.joint_armature[builder.joint_qd_start[names.index(joint)]] = float(value)
    return builder


def promote_mimics(builder: Any) -> int:
    """Move the MJCF importer's sparse mimic constraints onto their follower joints; how many."""
    pairs = zip(
        builder.constraint_mimic_joint0,
        builder.constraint_mimic_joint1,
        builder.constraint_mimic_coef0,
        builder.constraint_mimic_coef1,
    )
    count = 0
    for follower, leader, coef0, coef1 in pairs:
        builder.set_joint_mimic(joint=follower, reference_joint=leader, coeffs=(coef0, coef1))
        count += 1
    return count


def joint_names(labels: Any) -> list[str]:
    """Newton's joint labels (``svh_right/.../right_hand_j5``, ``/svh_right/joints/right_hand_j5``) as joint names."""
    return [str(label).rsplit("/", 1)[-1] for label in labels]


def load_newton(
    variant: str,
    file: str = "usd",
    device: str = "cpu",
    armature: Mapping[str, float] | None = None,
    gravity: float = -9.81,
) -> Any:
    """The variant as a finalized ``newton.Model`` on ``device`` (Warp's CPU by default)."""
    builder = builder_for(model_file(variant, file), file, armature, gravity)
    return builder.finalize(device=device)
