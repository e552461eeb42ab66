"""Check ``batch``: the batch model is the same robot, and MuJoCo Warp (CPU device) and MJX (JAX) take it.

Same robot: every kinematic, inertial, coupling and actuator array of ``<variant>_batch.xml`` equals the main
MJCF's; options and capacities are what the batch exporter promises (no noslip, Newton, elliptic,
implicitfast, Warp's solver tolerance, no multiccd, ``<size nconmax njmax>``), and no collision hull has more
than BATCH_MAX_HULL_VERTICES vertices.
Warp: put_model, make_data with the stated capacities, WARP_STEPS steps of WARP_WORLDS worlds towards random
servo targets without an overflow. MJX: put_model without a warning (it warns about hull faces above 20
vertices). MJX's jit of a step is not run: on this CPU it takes longer than the whole validation.

Both engines are optional extras (``batch``, ``batch-mjx``), not part of ``validate``'s: an engine that is not
installed, or MJX refusing a geom pair it does not implement (cylinder-mesh, ...), is that half skipped with the
reason; the check is skipped when neither half could run. Warp's banner and module-load lines are silenced.
"""

from __future__ import annotations

import warnings
from pathlib import Path
from typing import Any

import numpy as np

from svhdesc.extras import MissingExtra
from svhdesc.model import BATCH_MAX_HULL_VERTICES, BATCH_OPTIONS, BATCH_SCENE_FILE, BATCH_TOLERANCE
from svhdesc.validate.options import Options
from svhdesc.validate.pair import ModelPair
from svhdesc.validate.report import Check, not_run, skipped, summary, verdict

WARP_WORLDS = 4
WARP_STEPS = 50
# Model arrays that must be identical in the batch model: the same kinematics, masses, couplings, servos.
SAME = (
    "body_parentid",
    "body_pos",
    "body_quat",
    "body_mass",
    "body_inertia",
    "body_ipos",
    "body_iquat",
    "jnt_type",
    "jnt_axis",
    "jnt_range",
    "dof_damping",
    "dof_armature",
    "dof_frictionloss",
    "eq_type",
    "eq_obj1id",
    "eq_obj2id",
    "eq_data",
    "eq_solref",
    "eq_solimp",
    "actuator_trnid",
    "actuator_gainprm",
    "actuator_biasprm",
    "actuator_ctrlrange",
    "actuator_forcerange",
    "key_qpos",
    "key_ctrl",
    "opt.timestep",
)


def _field(model: Any, name: str) -> np.ndarray:
    obj = model
    for part in name.split("."):
        obj = getattr(obj, part)
    return np.asarray(obj)


def compare_to_main(main: Any, batch: Any) -> list[str]:
    """What differs between the main and the batch MjModel (empty: the same robot)."""
    problems = []
    for name in SAME:
        a, b = _field(main, name), _field(batch, name)
        if a.shape != b.shape or not np.array_equal(a, b):
            problems.append(f"{name} differs from the main model")
    if batch.opt.noslip_iterations:
        problems.append(f"noslip_iterations={batch.opt.noslip_iterations} (Warp and MJX have no noslip)")
    import mujoco

    expected = {
        "solver": mujoco.mjtSolver.mjSOL_NEWTON,
        "cone": mujoco.mjtCone.mjCONE_ELLIPTIC,
        "integrator": mujoco.mjtIntegrator.mjINT_IMPLICITFAST,
    }
    for key, value in expected.items():
        if int(getattr(batch.opt, key)) != int(value):
            problems.append(f"option {key} is not {BATCH_OPTIONS[key]}")
    if batch.opt.tolerance != BATCH_TOLERANCE:
        problems.append(f"solver tolerance {batch.opt.tolerance:g}, not the {BATCH_TOLERANCE:g} MuJoCo Warp uses")
    if not batch.opt.disableflags & mujoco.mjtDisableBit.mjDSBL_MULTICCD:
        problems.append("multiccd enabled (MuJoCo C and Warp choose its contacts differently)")
    if batch.nconmax <= 0 or batch.njmax <= 0:
        problems.append("no <size nconmax njmax>")
    mesh_type = int(mujoco.mjtGeom.mjGEOM_MESH)
    hulls = [g for g in range(batch.ngeom) if batch.geom_type[g] == mesh_type and batch.geom_contype[g]]
    for g in hulls:
        mesh = int(batch.geom_dataid[g])
        vertices = int(batch.mesh_graph[batch.mesh_graphadr[mesh]]) if batch.mesh_graphadr[mesh] >= 0 else 0
        if vertices > BATCH_MAX_HULL_VERTICES:
            problems.append(f"hull {batch.mesh(mesh).name} has {vertices} vertices > {BATCH_MAX_HULL_VERTICES}")
    return problems


def warp_rollout(model: Any, worlds: int = WARP_WORLDS, steps: int = WARP_STEPS, seed: int = 0) -> dict[str, int]:
    """Step ``worlds`` worlds towards random targets on Warp's CPU device; raises BatchOverflow on a drop."""
    from svhdesc.batch import BatchEnv  # starts Warp quietly (svhdesc.batch.device)

    env = BatchEnv(model, worlds, "cpu")
    env.reset("home")
    low, high = model.actuator_ctrlrange.T
    env.step(np.random.default_rng(seed).uniform(low, high, (worlds, model.nu)), nstep=steps)
    return {
        "worlds": worlds,
        "steps": steps,
        "nconmax": env.nconmax,
        "njmax": env.njmax,
        "contacts_last_step": int(env.data.nacon.numpy()[0]),
        "max_nefc_last_step": int(env.data.nefc.numpy().max()),
    }


def mjx_accepts(model: Any) -> list[str]:
    """MJX's put_model: the warnings it gives (an exception propagates)."""
    from mujoco import mjx

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        mjx.put_model(model)
    return [str(w.message).split(".")[0] for w in caught]


EXTRA = {"warp": "batch", "mjx": "batch-mjx"}


def _first_line(exc: BaseException) -> str:
    text = str(exc).strip()
    return f"{type(exc).__name__}: {text.splitlines()[0] if text else ''}"


def _engine(name: str, run: Any) -> tuple[str, Any]:
    """("ok", result), ("skipped", why) or ("refused", why)."""
    try:
        return "ok", run()
    except (ImportError, MissingExtra) as exc:  # ImportError: `from mujoco import mjx` without mujoco-mjx
        missing = getattr(exc, "name", None) or str(exc).strip().splitlines()[0]
        return "skipped", f"{name} not installed ({missing}; pip install 'svhdesc[{EXTRA[name]}]')"
    except NotImplementedError as exc:  # MJX has no collision function for some geom pairs (cylinder-mesh ...)
        return "skipped", f"{name} does not implement this model: {_first_line(exc)}"
    except Exception as exc:  # what the engine refuses is the finding
        return "refused", _first_line(exc)


def check_batch(pair: ModelPair, options: Options) -> list[Check]:
    bound = "same robot as the MJCF; Warp (CPU) steps without overflow; MJX put_model without warnings"
    scene = Path(pair.mjcf_path).parent / BATCH_SCENE_FILE
    if pair.model is None:
        return [not_run("batch", "the MJCF does not compile", bound)]
    if not scene.is_file():
        return [not_run("batch", f"{scene} does not exist (rebuild)", bound)]
    import mujoco

    batch = mujoco.MjModel.from_xml_path(str(scene))
    main = mujoco.MjModel.from_xml_path(str(pair.scene_path or pair.mjcf_path))
    problems = compare_to_main(main, batch)
    warp_status, warp = _engine("warp", lambda: warp_rollout(batch, seed=options.seed))
    mjx_status, mjx = _engine("mjx", lambda: mjx_accepts(batch))
    halves = {"warp": (warp_status, warp), "mjx": (mjx_status, mjx)}
    skips = [text for status, text in halves.values() if status == "skipped"]
    if len(skips) == len(halves) and not problems:
        return [skipped("batch", "; ".join(skips), bound)]
    if warp_status == "refused":
        problems.append(f"MuJoCo Warp: {warp}")
    if mjx_status == "refused":
        problems.append(f"MJX: {mjx}")
    elif mjx_status == "ok" and mjx:
        problems.append("MJX warns: " + "; ".join(mjx))
    measured = f"warp {warp_status}, mjx {mjx_status}"
    if warp_status == "ok":
        measured += f" (nconmax {warp['nconmax']}, njmax {warp['njmax']})"
    figures = {"warp": warp, "mjx": mjx, "problems": problems, "skipped": skips}
    ran = "; ".join(
        [f"{len(SAME)} arrays equal"]
        + ([f"Warp {warp}"] if warp_status == "ok" else [])
        + (["MJX put_model clean"] if mjx_status == "ok" else [])
        + [f"skipped: {text}" for text in skips]
    )
    return [Check("batch", verdict(not problems), measured, bound, summary(problems, ran), figures)]
