"""svhdesc.mjlab's entities against the built models, in .venv-mjlab (mjlab and its MuJoCo 3.11; skipped in .venv,
where tests/mjlab/test_in_mjlab_venv.py runs this file there): each variant's entity compiles to the batch model's
joints, actuators (gains, ranges), couplings (joint equalities, coefficients) and body masses, starts at its home
keyframe; and in Svh-Rotate's environment, 25 control steps of random actions keep every follower on its leader.
Seeded fault: a coupling dropped from the entity's spec fails the comparison."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

pytest.importorskip("mjlab")

import mujoco  # noqa: E402
import torch  # noqa: E402
from mjlab.entity import Entity  # noqa: E402

from svhdesc.mjlab import entity  # noqa: E402
from svhdesc.mjlab.mdp import coupling_residual  # noqa: E402
from svhdesc.validate.simulate import COUPLING_TOL  # noqa: E402

VARIANTS = ("svh_right", "svh_left", "ur5_svh_right")


def content(model: mujoco.MjModel) -> dict[str, Any]:
    """What an entity must keep of a model, by name (mjlab adds a world-fixed mocap body above the robot)."""
    joints = {model.joint(j).name: tuple(np.round(model.jnt_range[j], 9)) for j in range(model.njnt)}
    actuators = {
        model.actuator(a).name: (
            model.joint(int(model.actuator_trnid[a, 0])).name,
            tuple(model.actuator_ctrlrange[a]),
            tuple(model.actuator_forcerange[a]),
            tuple(model.actuator_gainprm[a, :3]),
            tuple(model.actuator_biasprm[a, :3]),
        )
        for a in range(model.nu)
    }
    equalities = {
        model.eq(e).name: (
            model.joint(int(model.eq_obj1id[e])).name,
            model.joint(int(model.eq_obj2id[e])).name,
            tuple(model.eq_data[e, :5]),
            bool(model.eq_active0[e]),
        )
        for e in range(model.neq)
    }
    masses = {model.body(b).name: float(model.body_mass[b]) for b in range(model.nbody) if model.body_mass[b] > 0}
    return {"joints": joints, "actuators": actuators, "equalities": equalities, "masses": masses}


def assert_same(cfg: Any, variant: str) -> None:
    built = entity.built(variant)
    reference = mujoco.MjModel.from_xml_path(str(built.model.batch_path))
    compiled = Entity(cfg).spec.compile()
    expected, found = content(reference), content(compiled)
    for part in expected:
        assert found[part] == expected[part], (variant, part)
    init = compiled.key("init_state").qpos
    home = reference.key("home").qpos
    assert np.allclose(init, home, atol=1e-12), (variant, "initial state is not the home keyframe")


@pytest.mark.parametrize("variant", VARIANTS)
def test_the_entity_is_the_built_model(variant: str) -> None:
    assert_same(entity.robot_cfg(variant), variant)
    scale = entity.action_scale(entity.built(variant))
    assert len(scale) == (15 if variant.startswith("ur5") else 9)
    assert all(value > 0 for value in scale.values())


def test_a_dropped_coupling_fails_the_comparison() -> None:
    """Seeded fault: the entity's spec without its first joint equality."""
    cfg = entity.robot_cfg("svh_right")
    load = cfg.spec_fn

    def without_coupling() -> mujoco.MjSpec:
        spec = load()
        spec.delete(spec.equalities[0])
        return spec

    cfg.spec_fn = without_coupling
    with pytest.raises(AssertionError, match="equalities"):
        assert_same(cfg, "svh_right")


def test_random_actions_keep_the_followers_on_their_leaders() -> None:
    """Svh-Rotate's environment (mjlab's managers, MuJoCo Warp on the CPU), 2 worlds, 25 control steps (0.5 s at
    20 physics steps each) of uniformly random actions: every coupled joint within COUPLING_TOL of its polynomial
    of the leader, as validate's coupling_tracking holds MuJoCo C's run."""
    from mjlab.envs import ManagerBasedRlEnv
    from mjlab.tasks.registry import load_env_cfg

    cfg = load_env_cfg("Svh-Rotate")
    cfg.scene.num_envs = 2
    env = ManagerBasedRlEnv(cfg=cfg, device="cpu")
    try:
        env.reset()
        robot = env.scene["robot"]
        couplings = entity.built("svh_right").couplings
        generator = torch.Generator().manual_seed(0)
        worst = 0.0
        for _ in range(25):
            action = torch.rand(2, env.action_manager.total_action_dim, generator=generator) * 2.0 - 1.0
            env.step(action)
            worst = max(worst, float(coupling_residual(robot, couplings).max()))
        assert len(couplings) == 11
        assert worst <= COUPLING_TOL, worst
    finally:
        env.close()


def test_the_consumers_table_runs_the_entity() -> None:
    """benchmarks/consumers.py's mjlab row (svhdesc.loaders.track's mjlab engine) runs this entity: the hand's 20
    joints and 11 couplings, the batch model's timestep as mjlab sets it."""
    from svhdesc.loaders.track import run, servo_plan

    mjcf = str(entity.built("svh_right").model.mjcf_path)
    found = run("mjlab", "mjcf", mjcf, servo_plan(mjcf), "MuJoCo C", seconds=0.01)
    assert found.error is None and found.engine == "mjlab", found.error
    assert (found.dof, len(found.mimics), len(found.q)) == (20, 11, 10)
