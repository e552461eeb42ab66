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


def test_boxes_overlap_as_the_six_face_normals_say() -> None:
    """The oriented-box test against the separating-axis rule written out (each box's three face normals, each box's
    reach along them the sum of its half sizes times |axis . normal|) on random boxes, about half of them apart.
    Seeded faults: leaving out the second box's normals, or its half sizes turned by R instead of R^T: both fail."""
    from scipy.spatial.transform import Rotation

    rng = np.random.default_rng(3)
    n = 4000
    aabb = np.concatenate([rng.normal(0, 0.01, (2 * n, 3)), rng.uniform(0.005, 0.03, (2 * n, 3))], axis=1)

    class Boxes:
        geom_aabb = aabb

    mats = Rotation.random(2 * n, random_state=4).as_matrix()
    pos = rng.uniform(-0.05, 0.05, (2 * n, 3))
    first, second = np.arange(n), np.arange(n, 2 * n)
    margin = rng.uniform(0, 0.002, n)
    got = batch_capacities._boxes_overlap(
        Boxes,
        (pos[first], mats[first].reshape(-1, 9)),
        (pos[second], mats[second].reshape(-1, 9)),
        first,
        second,
        margin,
    )
    want = np.ones(n, dtype=bool)
    for row in range(n):
        m1, m2 = mats[row], mats[n + row]
        c1, c2 = m1 @ aabb[row, :3] + pos[row], m2 @ aabb[n + row, :3] + pos[n + row]
        for normal in (*m1.T, *m2.T):
            reach1 = sum(abs(m1[:, j] @ normal) * aabb[row, 3 + j] for j in range(3))
            reach2 = sum(abs(m2[:, j] @ normal) * aabb[n + row, 3 + j] for j in range(3))
            if abs((c2 - c1) @ normal) > reach1 + reach2 + margin[row]:
                want[row] = False
    assert 0.2 < want.mean() < 0.8, want.mean()
    assert (got == want).all(), np.flatnonzero(got != want)[:10]
