"""Newton 1.8 loads every variant's USD, MJCF and URDF with its degrees of freedom, the spec's 11 couplings as joint
mimics and the budget's mass, and one second of the same servo targets tracks MuJoCo C: with its own Featherstone
solver (Warp's CPU) in .venv, and with SolverMuJoCo (MuJoCo 3.17, ``newton[sim]``) in .venv-newton.

Seeded faults, each failing here: the USD's mimic ratio inverted (coef1 = 1 / ratio: couplings kept 0 of 11 in
every variant's USD); ``load_newton`` not moving the MJCF's couplings onto the joints (``promote_mimics`` a no-op:
0 of 11, and the fingers' followers left free); the URDF's armature not filled in from the MJCF (Featherstone's step
diverges: NaN); a USD cut short (one line naming the engine, the file and usd-core's parse error)."""

from __future__ import annotations

import math
import os
from pathlib import Path

import numpy as np
import pytest

import svhdesc
from svhdesc.loaders import couplings, load_newton
from svhdesc.loaders.newton import FILES, model_file
from svhdesc.loaders.track import Run, compare, run_in, run_mujoco, run_newton, servo_plan
from svhdesc.loaders.track import run as track_run
from tests.support import REPO, VARIANTS

NEWTON_PYTHON = Path(os.environ.get("SVHDESC_NEWTON_PYTHON", REPO / ".venv-newton" / "bin" / "python"))
MASS_TOL = 1e-3  # relative: 0.1 %
TRACKED = "svh_right"
# rad over 1 s. Newton reduces each coupling exactly; MuJoCo C holds it by a soft joint equality (solref 0.002),
# which lets a coupled chain start faster: the pinky's distal joint is up to 0.057 rad ahead (docs/consumers.md).
FEATHERSTONE_GAP = 0.08
SAME_PHYSICS_GAP = 2e-3  # SolverMuJoCo on the MJCF: MuJoCo C with the same equalities, torques applied by Newton
EXACT_RESIDUAL = 1e-5  # rad: Featherstone's reduction (float32)
SOFT_RESIDUAL = 2e-3  # rad: SolverMuJoCo's mimic equalities


def _spec(variant: str) -> list[tuple[str, str, float, float]]:
    return [(c.joint, c.leader, c.offset, c.multiplier) for c in couplings(variant)]


# How long each file is tracked: the USD (what Newton's users load) a full second, the others long enough to catch a
# coupling left free or a step that diverges (all three give the same motion: docs/results/consumers.md).
SECONDS = {"usd": 1.0, "mjcf": 0.25, "urdf": 0.25}


@pytest.fixture(scope="module")
def plan() -> dict:
    return servo_plan(str(svhdesc.get(TRACKED).mjcf_path))


def _reference(plan: dict, seconds: float) -> Run:
    return run_mujoco(str(svhdesc.get(TRACKED).mjcf_path), plan, seconds)


@pytest.mark.parametrize("file", FILES)
def test_featherstone_loads_every_variant_and_tracks_mujoco(file: str, plan: dict) -> None:
    for variant in VARIANTS:
        mujoco_model = svhdesc.load_mujoco(variant)
        variant_plan = servo_plan(str(svhdesc.get(variant).mjcf_path))
        loaded = run_newton(model_file(variant, file), file, variant_plan, seconds=0.0)
        assert loaded.error is None
        assert loaded.dof == mujoco_model.nv, (variant, file)
        assert math.isclose(loaded.mass, float(np.sum(mujoco_model.body_mass)), rel_tol=MASS_TOL), (variant, file)
        held = sorted((f, leader, round(ratio, 6)) for f, leader, _, ratio in loaded.mimics)
        assert held == sorted((f, leader, round(ratio, 6)) for f, leader, _, ratio in _spec(variant)), (variant, file)
    run = run_newton(model_file(TRACKED, file), file, plan, seconds=SECONDS[file])
    figures = compare(_reference(plan, SECONDS[file]), run, _spec(TRACKED))
    assert figures.mimics_kept == 11 and figures.deviation <= FEATHERSTONE_GAP, (file, figures)
    assert figures.residual <= EXACT_RESIDUAL, (file, figures)


def test_load_newton_gives_a_model_with_the_mimics() -> None:
    model = load_newton(TRACKED)  # the USD
    leaders = model.joint_mimic_joint.numpy()
    assert int(np.sum(leaders >= 0)) == 11 and model.joint_dof_count == 20
    with pytest.raises(ValueError, match="file must be one of usd, mjcf, urdf"):
        load_newton(TRACKED, "sdf")


def test_solver_mujoco_in_its_environment(plan: dict) -> None:
    """Newton's SolverMuJoCo (MuJoCo 3.17, .venv-newton) on the MJCF, whose equalities it keeps, gives MuJoCo C's
    own motion; on the USD, whose mimics are hard, Featherstone's."""
    assert NEWTON_PYTHON.is_file(), f"{NEWTON_PYTHON} is missing: bash tools/install.sh test makes it"
    spec = _spec(TRACKED)
    for file in ("usd", "mjcf"):
        run = run_in(str(NEWTON_PYTHON), "newton", file, model_file(TRACKED, file), plan, "mujoco", SECONDS[file])
        assert run.error is None, run.error
        assert run.version == "1.8.0" and run.dof == 20
        figures = compare(_reference(plan, SECONDS[file]), run, spec)
        assert figures.mimics_kept == 11, (file, run.mimics)
        bound = SAME_PHYSICS_GAP if file == "mjcf" else FEATHERSTONE_GAP
        assert figures.deviation <= bound, (file, figures)
        assert figures.residual <= SOFT_RESIDUAL, (file, figures)


def test_a_file_newton_cannot_read_is_one_line(tmp_path: Path, plan: dict) -> None:
    usd = svhdesc.get(TRACKED).usd_path.read_text()
    cut = tmp_path / "cut.usda"
    cut.write_text(usd[: len(usd) // 3])
    run = track_run("newton", "usd", str(cut), plan, "featherstone", seconds=0.0)
    assert run.engine == "newton" and run.file == "usd" and run.q == []
    assert run.error and "\n" not in run.error and "cut.usda" in run.error and "parse error" in run.error
    missing = run_in(str(tmp_path / "no-python"), "newton", "usd", str(cut), plan, seconds=0.0)
    assert missing.error and missing.error.startswith("FileNotFoundError")


def test_the_physx_mimics_alone_give_newton_the_couplings(tmp_path: Path) -> None:
    """Isaac Sim's schema (PhysxMimicJointAPI: q + gearing q_leader + offset = 0), read by Newton's own PhysX reader
    once NewtonMimicAPI, which takes precedence, is removed: the same 11 couplings with the spec's ratios. Seeded
    fault: gearing written as +ratio (Newton then holds -ratio, and this fails)."""
    import newton_usd_schemas  # noqa: F401  registers NewtonMimicAPI with usd-core
    from pxr import Usd

    stage = Usd.Stage.Open(str(svhdesc.get(TRACKED).usd_path))
    stripped = 0
    for prim in stage.Traverse():
        if (
            "NewtonMimicAPI" in prim.GetMetadata("apiSchemas").GetAppliedItems()
            if prim.HasMetadata("apiSchemas")
            else ()
        ):
            prim.RemoveAppliedSchema("NewtonMimicAPI")
            for name in ("newton:mimicEnabled", "newton:mimicCoef0", "newton:mimicCoef1"):
                prim.RemoveProperty(name)
            prim.RemoveProperty("newton:mimicJoint")
            stripped += 1
    physx_only = tmp_path / "physx_only.usda"
    stage.GetRootLayer().Export(str(physx_only))
    assert stripped == 11 and "newton:mimicCoef1" not in physx_only.read_text()
    loaded = run_newton(str(physx_only), "usd", servo_plan(str(svhdesc.get(TRACKED).mjcf_path)), seconds=0.0)
    held = sorted((f, leader, round(offset, 9), round(ratio, 6)) for f, leader, offset, ratio in loaded.mimics)
    assert held == sorted((f, leader, round(offset, 9), round(ratio, 6)) for f, leader, offset, ratio in _spec(TRACKED))
