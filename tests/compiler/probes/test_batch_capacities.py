"""The batch capacities' broadphase replica: its body-sphere prefilter leaves out no pair the exact tests would pass."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

import svhdesc
from svhdesc.compiler.probes import batch_capacities


def rollout(variant: str, steps: int) -> tuple[mujoco.MjModel, tuple[np.ndarray, ...]]:
    """States of the variant's batch scene closing into a fist from home: geom and body frames per step."""
    model = mujoco.MjModel.from_xml_path(str(svhdesc.get(variant).batch_scene_path))
    data = mujoco.MjData(model)
    mujoco.mj_resetDataKeyframe(model, data, model.key("home").id)
    data.ctrl[:] = model.actuator_ctrlrange[:, 1]
    frames = [], [], [], []
    for _ in range(steps):
        mujoco.mj_step(model, data)
        for kept, value in zip(frames, (data.geom_xpos, data.geom_xmat, data.xpos, data.xmat)):
            kept.append(value.copy())
    return model, tuple(np.array(f) for f in frames)


@pytest.mark.parametrize("variant", ["svh_right", "ur5_svh_right"])
def test_body_spheres_hold_their_geoms_and_change_no_count(variant: str, monkeypatch: pytest.MonkeyPatch) -> None:
    """Counts with the prefilter equal those with every body pair let through (a sphere of 1 km per body).
    Seeded fault: body spheres that forget their geoms' bounding radii give fewer candidates."""
    model, (xpos, xmat, body_xpos, body_xmat) = rollout(variant, 400)
    pairs = batch_capacities.collision_pairs(model)
    centre, radius = batch_capacities.body_spheres(model)
    solid = model.geom_rbound > 0
    inside = np.linalg.norm(model.geom_pos - centre[model.geom_bodyid], axis=1) + model.geom_rbound
    assert (inside[solid] <= radius[model.geom_bodyid[solid]] + 1e-12).all()
    counts = batch_capacities.broadphase_candidates(model, xpos, xmat, (body_xpos, body_xmat), pairs)
    assert counts.max() > 0
    real = batch_capacities.body_spheres
    monkeypatch.setattr(batch_capacities, "body_spheres", lambda m: (real(m)[0], np.full(m.nbody, 1e3)))
    unfiltered = batch_capacities.broadphase_candidates(model, xpos, xmat, (body_xpos, body_xmat), pairs)
    assert (counts == unfiltered).all()
