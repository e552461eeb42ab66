"""The batch model and svhdesc.batch on MuJoCo Warp's CPU device: the same robot as MuJoCo C, step for step.

Warp compiles its kernels once per machine into the repo's ignored .cache/warp (about 30 s on the first run).
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pytest

from tests.support import REPO

os.environ.setdefault("WARP_CACHE_PATH", str(REPO / ".cache" / "warp"))

mujoco = pytest.importorskip("mujoco")
pytest.importorskip("mujoco_warp")

import svhdesc  # noqa: E402
from svhdesc.batch import BatchEnv, BatchOverflow, make  # noqa: E402
from svhdesc.compare import experiment  # noqa: E402
from svhdesc.model import couplings  # noqa: E402
from svhdesc.validate.batch import compare_to_main  # noqa: E402

WORLDS = 16
SECONDS = 1.0
QPOS_BOUND = 1e-3  # rad at 1 s, Warp (float32) against MuJoCo C (float64)
COUPLING_BOUND = 1e-3  # rad
# A world is chaotic when MuJoCo C itself, with float32-sized perturbations (its state rounded to float32 after
# every step, or its start offset by OFFSET rad), ends more than CHAOS rad from its own unperturbed rollout: fingers
# that bounce on each other amplify any rounding. Such worlds are held to max(QPOS_BOUND, CHAOS_FACTOR x that
# spread); every other world to QPOS_BOUND, with the same body pairs touching during the rollout.
CHAOS = 0.1 * QPOS_BOUND
CHAOS_FACTOR = 2.0
OFFSET = 1e-7  # rad
STEADY_WORLDS = 10  # at least this many of WORLDS must be steady: the strict bound must cover most of the batch


def mujoco_c(model, keyframe: str, ctrl: np.ndarray, steps: int, ramp_from: np.ndarray | None = None) -> np.ndarray:
    """qpos [world, nq] after ``steps`` steps of MuJoCo C per world (ctrl held, or ramped from ``ramp_from``)."""
    data = mujoco.MjData(model)
    key = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_KEY, keyframe)
    result = []
    for world in range(len(ctrl)):
        mujoco.mj_resetDataKeyframe(model, data, key)
        for step in range(steps):
            data.ctrl[:] = ctrl[world] if ramp_from is None else ramp(ramp_from[world], ctrl[world], step, steps)
            mujoco.mj_step(model, data)
        result.append(data.qpos.copy())
    return np.array(result)


def c_rollouts(
    model, keyframe: str, ctrl: np.ndarray, steps: int, perturb: str = ""
) -> tuple[np.ndarray, list[set[tuple[int, int]]]]:
    """MuJoCo C per world, ctrl held: qpos at the end and the body pairs that touched at any step.

    ``perturb``: "float32" rounds qpos and qvel to float32 after every step, "offset" adds OFFSET to the start.
    """
    data = mujoco.MjData(model)
    key = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_KEY, keyframe)
    result, touched = [], []
    for world in range(len(ctrl)):
        mujoco.mj_resetDataKeyframe(model, data, key)
        data.qpos[:] += OFFSET if perturb == "offset" else 0.0
        data.ctrl[:] = ctrl[world]
        pairs: set[tuple[int, int]] = set()
        for _ in range(steps):
            mujoco.mj_step(model, data)
            if perturb == "float32":
                data.qpos[:], data.qvel[:] = data.qpos.astype(np.float32), data.qvel.astype(np.float32)
            pairs |= body_pairs(model, [(c.geom1, c.geom2) for c in data.contact[: data.ncon]])
        result.append(data.qpos.copy())
        touched.append(pairs)
    return np.array(result), touched


def body_pairs(model, geoms) -> set[tuple[int, int]]:
    return {tuple(sorted((int(model.geom_bodyid[a]), int(model.geom_bodyid[b])))) for a, b in geoms}


def warp_touching(env: BatchEnv) -> list[set[tuple[int, int]]]:
    count = int(env.data.nacon.numpy()[0])
    geoms, worlds = env.data.contact.geom.numpy()[:count], env.data.contact.worldid.numpy()[:count]
    return [body_pairs(env.mjm, geoms[worlds == w]) for w in range(env.nworld)]


def warp_rollout(env: BatchEnv, ctrl: np.ndarray, steps: int) -> tuple[dict[str, np.ndarray], list[set]]:
    """Observations after ``steps`` steps from keyframe home, and the body pairs that touched at any step."""
    env.reset("home")
    env.set_ctrl(ctrl)
    touched: list[set[tuple[int, int]]] = [set() for _ in range(env.nworld)]
    for _ in range(steps):
        env.step()
        for world, pairs in enumerate(warp_touching(env)):
            touched[world] |= pairs
    return env.observations(), touched


def ramp(start: np.ndarray, goal: np.ndarray, step: int, steps: int) -> np.ndarray:
    return start + (goal - start) * min(1.0, step / (steps / 2))  # reach the goal at half time, then hold


def coupling_residual(model, qpos: np.ndarray) -> float:
    worst = 0.0
    for c in couplings(model):
        joint, leader = model.joint(c.joint).qposadr[0], model.joint(c.leader).qposadr[0]
        expected = sum(k * qpos[:, leader] ** i for i, k in enumerate(c.coeffs))
        worst = max(worst, float(np.abs(qpos[:, joint] - expected).max()))
    return worst


def equivalence(model, ctrl: np.ndarray, steps: int, warp_qpos: np.ndarray, warp_touched: list[set]) -> dict:
    """Warp's rollouts against MuJoCo C's of ``model``: per-world errors, chaos, and what breaks the bounds."""
    reference, touched = c_rollouts(model, "home", ctrl, steps)
    spread = np.zeros(len(ctrl))
    for perturb in ("float32", "offset"):
        spread = np.maximum(spread, np.abs(c_rollouts(model, "home", ctrl, steps, perturb)[0] - reference).max(axis=1))
    error = np.abs(warp_qpos - reference).max(axis=1)
    steady = spread <= CHAOS
    failures = []
    if steady.sum() < STEADY_WORLDS:
        failures.append(f"only {steady.sum()} steady worlds")
    failures += [f"world {w}: {error[w]:.2e} rad" for w in np.flatnonzero(steady & (error > QPOS_BOUND))]
    failures += [f"world {w}: other pairs touch" for w in np.flatnonzero(steady) if warp_touched[w] != touched[w]]
    chaotic_bound = np.maximum(QPOS_BOUND, CHAOS_FACTOR * spread)
    failures += [f"chaotic world {w}: {error[w]:.2e} rad" for w in np.flatnonzero(error > chaotic_bound)]
    moved = np.abs(reference - model.key_qpos[0]).max()
    return {"error": error, "spread": spread, "steady": steady, "failures": failures, "moved": moved}


def test_batch_model_is_the_same_robot() -> None:
    model = svhdesc.get("svh_right")
    main = mujoco.MjModel.from_xml_path(str(model.scene_path))
    batch = mujoco.MjModel.from_xml_path(str(model.batch_scene_path))
    assert compare_to_main(main, batch) == []
    assert main.opt.noslip_iterations > 0 and batch.opt.noslip_iterations == 0
    assert batch.nconmax > 0 and batch.njmax > 0
    # Seeded faults: a heavier link, a noslip pass, an unsized model, a coupling off by a gain, C's own solver
    # tolerance (Warp would use 1e-6), multiccd on (C and Warp choose its contacts differently).
    for edit in ("body_mass", "noslip", "size", "eq_data", "tolerance", "multiccd"):
        faulty = mujoco.MjModel.from_xml_path(str(model.batch_scene_path))
        if edit == "body_mass":
            faulty.body_mass[3] *= 1.01
        elif edit == "noslip":
            faulty.opt.noslip_iterations = 5
        elif edit == "size":
            faulty = _unsized(model.batch_path)
        elif edit == "tolerance":
            faulty.opt.tolerance = 1e-8
        elif edit == "multiccd":
            faulty.opt.disableflags &= ~int(mujoco.mjtDisableBit.mjDSBL_MULTICCD)
        else:
            faulty.eq_data[0, 1] += 1e-6
        assert compare_to_main(main, faulty), edit


def _unsized(batch_path: Path):
    spec = mujoco.MjSpec.from_file(str(batch_path))
    spec.nconmax, spec.njmax = -1, -1
    return spec.compile()


def test_equivalence_random_targets() -> None:
    """16 worlds, each towards its own random servo targets for 1 s: Warp's CPU device against MuJoCo C."""
    env = make("svh_right", nworld=WORLDS, device="cpu")
    model = env.mjm
    low, high = model.actuator_ctrlrange.T
    ctrl = np.random.default_rng(7).uniform(low, high, (WORLDS, model.nu))
    steps = int(round(SECONDS / model.opt.timestep))
    warp, touched = warp_rollout(env, ctrl, steps)
    result = equivalence(model, ctrl, steps, warp["qpos"], touched)
    error, spread, steady = result["error"], result["spread"], result["steady"]
    chaotic = ", ".join(f"world {w}: {error[w]:.1e} (C {spread[w]:.1e})" for w in np.flatnonzero(~steady))
    print(
        f"\n|qpos warp - qpos C| at {SECONDS:g} s: {steady.sum()} of {WORLDS} worlds steady (C moves at most "
        f"{spread[steady].max():.1e} rad under float32-sized perturbations): max {error[steady].max():.2e} rad "
        f"(bound {QPOS_BOUND:g}); chaotic, fingers bouncing on each other: {chaotic or 'none'}; all worlds: max "
        f"{error.max():.2e} rad, {(error <= QPOS_BOUND).sum()} within {QPOS_BOUND:g}; joints moved up to "
        f"{result['moved']:.3f} rad"
    )
    assert result["moved"] > 0.3  # the targets really move the hand
    assert result["failures"] == []
    assert any(touched), "no world touched anything: the same-pairs check would test nothing"
    residual = coupling_residual(model, warp["qpos"])
    print(f"coupling residual in Warp: {residual:.2e} rad (bound {COUPLING_BOUND:g})")
    assert residual <= COUPLING_BOUND
    assert warp["fingertips"].shape == (WORLDS, 5, 3) and warp["touch"].shape == (WORLDS, 1)
    # Seeded fault: MuJoCo C with the drives' damping 5 % higher is another robot; the comparison must say so.
    faulty = mujoco.MjModel.from_xml_path(str(svhdesc.get("svh_right").batch_scene_path))
    faulty.dof_damping[:] *= 1.05
    failures = equivalence(faulty, ctrl, steps, warp["qpos"], touched)["failures"]
    print(f"seeded fault (C damping +5 %): {len(failures)} failures, e.g. {failures[:2]}")
    assert any(f.startswith("world") and "rad" in f for f in failures), failures


def test_contact_scene_keeps_the_fingertip_contact() -> None:
    """The thesis' contact experiment, batched: the index tip presses the surface in every world, as in C."""
    path = svhdesc.get("svh_right").batch_scene_path
    spec = mujoco.MjSpec.from_file(str(path))
    surface = experiment.place_surface(mujoco.MjModel.from_xml_path(str(path)))
    experiment.add_surface(spec, surface)
    model = spec.compile()
    worlds = 4
    home, test = experiment.keyframes(model)
    # Each world presses with the test targets scaled a little differently (still reaching the surface).
    scale = np.linspace(1.0, 1.02, worlds)[:, None]
    goal = np.clip(model.key_ctrl[test] * scale, *model.actuator_ctrlrange.T)
    start = np.repeat(model.key_ctrl[home][None], worlds, axis=0)
    steps = int(round(SECONDS / model.opt.timestep))
    env = BatchEnv(model, worlds, "cpu")
    env.reset("home")
    for step in range(steps):
        env.step(np.array([ramp(start[w], goal[w], step, steps) for w in range(worlds)]))
    warp = env.observations()
    reference = mujoco_c(model, "home", goal, steps, ramp_from=start)
    error = np.abs(warp["qpos"] - reference).max()
    print(f"\ncontact scene: max |qpos warp - qpos C| at {SECONDS} s: {error:.2e} rad; touch {warp['touch'].ravel()}")
    assert (warp["touch"] > 0).all(), "a fingertip lost the surface in Warp"
    data = mujoco.MjData(model)
    data.qpos[:] = reference[0]
    mujoco.mj_forward(model, data)
    tip = experiment.fingertip(model)[0]
    assert model.body(tip).name in experiment.bodies_touching(model, data, model.geom(experiment.SURFACE).id)
    assert error <= QPOS_BOUND
    assert coupling_residual(model, warp["qpos"]) <= COUPLING_BOUND


def test_overflow_raises_and_reset_is_per_world() -> None:
    env = make("svh_right", nworld=2, device="cpu")
    env.reset("home")
    env.reset("test", worlds=[1])
    obs = env.observations()
    assert np.allclose(obs["qpos"][0], env.mjm.key_qpos[0]) and np.allclose(obs["qpos"][1], env.mjm.key_qpos[1])
    closed = np.tile(env.mjm.actuator_ctrlrange[:, 1], (2, 1))
    env.step(closed, nstep=5)  # the stated capacities hold
    # Seeded fault: capacities too small for the fist the hand closes into -> raise, never drop silently.
    small = make("svh_right", nworld=2, device="cpu", nconmax=1, njmax=4)
    small.reset("home")
    with pytest.raises(BatchOverflow, match="overflow"):
        small.step(closed, nstep=300)


def test_capacity_sizing_sees_the_pairs_warp_tests() -> None:
    """The build's broadphase replica starts from the same collision pairs as MuJoCo Warp's."""
    import warp as wp
    from mujoco_warp import put_model

    from svhdesc.compiler.probes.batch_capacities import collision_pairs

    path = svhdesc.get("ur5_svh_right").batch_scene_path
    model = mujoco.MjModel.from_xml_path(str(path))
    with wp.ScopedDevice("cpu"):
        warp_pairs = {tuple(p) for p in put_model(model).nxn_geom_pair_filtered.numpy().tolist()}
    assert {tuple(p) for p in collision_pairs(model).tolist()} == warp_pairs
    # Seeded fault: the same model without its self-collision exclusions gives other pairs.
    spec = mujoco.MjSpec.from_file(str(path))
    for exclude in list(spec.excludes):
        spec.delete(exclude)
    assert {tuple(p) for p in collision_pairs(spec.compile()).tolist()} != warp_pairs


def test_mjx_accepts_the_batch_scene_not_the_main_one() -> None:
    """MJX (JAX on CPU) takes ur5_svh_right's batch scene; the main scene (cylinder pedestal) it refuses."""
    pytest.importorskip("mujoco.mjx")
    from svhdesc.validate.batch import mjx_accepts

    model = svhdesc.get("ur5_svh_right")
    assert mjx_accepts(mujoco.MjModel.from_xml_path(str(model.batch_scene_path))) == []
    with pytest.raises(NotImplementedError, match="CYLINDER"):
        mjx_accepts(mujoco.MjModel.from_xml_path(str(model.scene_path)))
