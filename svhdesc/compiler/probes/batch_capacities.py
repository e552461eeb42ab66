"""Size the batch model's contact and constraint capacities from a sampled worst case (MuJoCo C, build time).

Rollouts of ROLLOUT_S seconds in ``scene_batch.xml`` from keyframe ``home`` (else qpos0), servo targets held:
every actuator at its lower limit, every one at its upper limit (a closed fist, an open hand), then
RANDOM_ROLLOUTS draws uniform in the control ranges (fixed seed: the build stays deterministic). The most
contacts, constraint rows and broadphase candidates any step had are the worst case.

MuJoCo Warp keeps broadphase candidates in a buffer of the same capacity, so they count: a candidate here
is a geom pair MuJoCo's filters let collide (contype/conaffinity, excludes, same or parent body) that passes
Warp's default broadphase tests (see broadphase_candidates), evaluated on MuJoCo C's double-precision state.
"""

from __future__ import annotations

import tempfile
from dataclasses import asdict
from pathlib import Path
from typing import Any

import numpy as np

from svhdesc.compiler.export.batch import Capacities
from svhdesc.compiler.probes.cache import cache_dir, content_key, remembered

ROLLOUT_S = 1.0
RANDOM_ROLLOUTS = 4
SEED = 0
CHUNK = 100  # states per vectorised broadphase evaluation


def _targets(model: object) -> list[np.ndarray]:
    low, high = model.actuator_ctrlrange[:, 0], model.actuator_ctrlrange[:, 1]  # type: ignore[attr-defined]
    rng = np.random.default_rng(SEED)
    return [low.copy(), high.copy(), *(rng.uniform(low, high) for _ in range(RANDOM_ROLLOUTS))]


def collision_pairs(model: Any) -> np.ndarray:
    """Geom pairs MuJoCo's filters allow to collide (rows of two geom ids), as in mj_collision."""
    weld = model.body_weldid
    parent_weld = weld[model.body_parentid[weld]]
    excluded = set(int(s) for s in model.exclude_signature)
    filterparent = not model.opt.disableflags & 1 << 9  # mjDSBL_FILTERPARENT
    pairs = []
    for g1 in range(model.ngeom):
        for g2 in range(g1 + 1, model.ngeom):
            type1, type2 = model.geom_contype, model.geom_conaffinity
            if not (type1[g1] & type2[g2] or type1[g2] & type2[g1]):
                continue
            b1, b2 = int(model.geom_bodyid[g1]), int(model.geom_bodyid[g2])
            w1, w2 = int(weld[b1]), int(weld[b2])
            if w1 == w2:
                continue
            if filterparent and w1 != 0 and w2 != 0 and (parent_weld[b1] == w2 or parent_weld[b2] == w1):
                continue
            if (min(b1, b2) << 16) + max(b1, b2) in excluded:
                continue
            pairs.append((g1, g2))
    return np.array(pairs, dtype=int).reshape(-1, 2)


def body_spheres(model: Any) -> tuple[np.ndarray, np.ndarray]:
    """Per body, a sphere holding every bounding sphere of its geoms (planes left out): its centre in the body's
    frame (the middle of the box around those spheres) and its radius. Zero radius for a body without them."""
    solid = model.geom_rbound > 0
    low = np.full((model.nbody, 3), np.inf)
    high = np.full((model.nbody, 3), -np.inf)
    reach = model.geom_rbound[:, None]
    np.minimum.at(low, model.geom_bodyid[solid], (model.geom_pos - reach)[solid])
    np.maximum.at(high, model.geom_bodyid[solid], (model.geom_pos + reach)[solid])
    empty = ~np.isfinite(low)  # no solid geom: a zero sphere at the body's origin
    low[empty], high[empty] = 0.0, 0.0
    centre = (low + high) / 2
    extent = np.linalg.norm(model.geom_pos - centre[model.geom_bodyid], axis=1) + model.geom_rbound
    radius = np.zeros(model.nbody)
    np.maximum.at(radius, model.geom_bodyid, np.where(solid, extent, 0.0))
    return centre, radius


def broadphase_candidates(
    model: Any,
    xpos: np.ndarray,
    xmat: np.ndarray,
    body_frames: tuple[np.ndarray, np.ndarray],
    pairs: np.ndarray,
) -> np.ndarray:
    """Per state, the pairs that pass Warp's default broadphase: bounding spheres overlap, then oriented bounding
    boxes overlap along the six face normals (mj_collideOBB); a plane and a bounding sphere that reaches it.

    ``xpos`` (T x ngeom x 3) and ``xmat`` (T x ngeom x 9) are T states' geom_xpos and geom_xmat, ``body_frames``
    their bodies' xpos (T x nbody x 3) and xmat (T x nbody x 9); one count each. Body spheres holding their geoms'
    spheres (``body_spheres``) only pick the pairs worth the exact tests: a pair they leave out cannot pass them.
    """
    g1, g2 = pairs[:, 0], pairs[:, 1]
    r1, r2 = model.geom_rbound[g1], model.geom_rbound[g2]
    margin = model.geom_margin[g1] + model.geom_margin[g2] + model.geom_gap[g1] + model.geom_gap[g2]
    reach = r1 + r2 + margin
    # A plane (bounding radius 0) against a geom whose bounding sphere reaches it; the plane's normal is local z.
    rows = np.flatnonzero((r1 == 0) | (r2 == 0))
    off, normal1, normal2 = (
        xpos[:, g2[rows]] - xpos[:, g1[rows]],
        xmat[:, g1[rows]][..., 2::3],
        xmat[:, g2[rows]][..., 2::3],
    )
    above1 = (off * normal1).sum(axis=2) <= r2[rows] + margin[rows]
    above2 = (-off * normal2).sum(axis=2) <= r1[rows] + margin[rows]
    hits = (np.where(r1[rows] == 0, above1, False) | np.where(r2[rows] == 0, above2, False)).sum(axis=1)
    step, pair = _near_bodies(model, body_frames, pairs, margin)
    # Flat (state, geom) indices: one gather per array instead of two-dimensional fancy indexing.
    ngeom = model.ngeom
    at1, at2 = step * ngeom + g1[pair], step * ngeom + g2[pair]
    flat_pos, flat_mat = xpos.reshape(-1, 3), xmat.reshape(-1, 9)
    offset = flat_pos[at2] - flat_pos[at1]
    keep = (offset * offset).sum(axis=1) <= reach[pair] * reach[pair]
    step, pair, at1, at2 = step[keep], pair[keep], at1[keep], at2[keep]
    boxes = _boxes_overlap(
        model,
        (flat_pos[at1], flat_mat[at1]),
        (flat_pos[at2], flat_mat[at2]),
        g1[pair],
        g2[pair],
        margin[pair],
    )
    return hits + np.bincount(step[boxes], minlength=len(hits))


def _near_bodies(
    model: Any, body_frames: tuple[np.ndarray, np.ndarray], pairs: np.ndarray, margin: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """(state, row of ``pairs``) for every solid pair whose bodies' spheres (``body_spheres``) overlap: the body
    pairs are tested once per state, and only the near ones expand to their geom pairs."""
    g1, g2 = pairs[:, 0], pairs[:, 1]
    solid = np.flatnonzero((model.geom_rbound[g1] > 0) & (model.geom_rbound[g2] > 0))
    b1, b2 = model.geom_bodyid[g1[solid]], model.geom_bodyid[g2[solid]]
    body_pairs, index = np.unique(b1 * model.nbody + b2, return_inverse=True)
    first, second = np.divmod(body_pairs, model.nbody)
    centre, radius = body_spheres(model)
    slack = radius[first] + radius[second] + margin.max(initial=0.0) + 1e-9  # 1e-9 m: rounding, never a miss
    body_xpos, body_xmat = body_frames
    middle = body_xpos + np.einsum("tbij,bj->tbi", body_xmat.reshape(*body_xmat.shape[:2], 3, 3), centre)
    apart = middle[:, second] - middle[:, first]
    step, near = np.nonzero((apart * apart).sum(axis=2) <= slack * slack)
    # The solid rows grouped by body pair (CSR): each near body pair brings its own rows.
    grouped = np.argsort(index, kind="stable")
    count = np.bincount(index, minlength=len(body_pairs))
    start = np.cumsum(count) - count
    sizes = count[near]
    within = np.arange(sizes.sum()) - np.repeat(np.cumsum(sizes) - sizes, sizes)
    return np.repeat(step, sizes), solid[grouped[np.repeat(start[near], sizes) + within]]


def _boxes_overlap(
    model: Any,
    frame1: tuple[np.ndarray, np.ndarray],
    frame2: tuple[np.ndarray, np.ndarray],
    g1: np.ndarray,
    g2: np.ndarray,
    margin: np.ndarray,
) -> np.ndarray:
    """Per row, whether oriented bounding boxes (geom_aabb in each geom frame) overlap along the six face normals;
    row n pairs geoms g1[n] and g2[n], placed at frame1[n] and frame2[n] (xpos, xmat). Along a face normal of one
    box, that box reaches its own half size and the other the sum of its half sizes weighted by |mat1^T mat2|."""
    mat1, mat2 = frame1[1].reshape(-1, 3, 3), frame2[1].reshape(-1, 3, 3)
    aabb1, aabb2 = model.geom_aabb[g1].reshape(-1, 2, 3), model.geom_aabb[g2].reshape(-1, 2, 3)
    half1, half2 = aabb1[:, 1], aabb2[:, 1]
    apart = (
        np.matmul(mat2, aabb2[:, 0, :, None])[..., 0] + frame2[0] - np.matmul(mat1, aabb1[:, 0, :, None])[..., 0]
    ) - frame1[0]
    turn = np.abs(np.matmul(mat1.transpose(0, 2, 1), mat2))  # |R|, R[j, k] = axis j of box 1 . axis k of box 2
    gap1 = np.abs(np.matmul(apart[:, None, :], mat1)[:, 0])  # along box 1's axes
    gap2 = np.abs(np.matmul(apart[:, None, :], mat2)[:, 0])
    reach1 = half1 + np.matmul(turn, half2[..., None])[..., 0] + margin[:, None]
    reach2 = np.matmul(half1[:, None, :], turn)[:, 0] + half2 + margin[:, None]
    return (reach1 >= gap1).all(axis=1) & (reach2 >= gap2).all(axis=1)


def cached_capacities(scene_xml: bytes, model_name: str, model_xml: bytes, assets: Path) -> Capacities:
    """``sample_capacities``, remembered by content (``svhdesc.compiler.probes.cache``)."""
    plan = repr((ROLLOUT_S, RANDOM_ROLLOUTS, SEED, CHUNK)).encode() + Path(__file__).read_bytes()  # and this code
    files = {path.name: path.read_bytes() for path in assets.iterdir()}
    return remembered(
        cache_dir("capacities"),
        content_key((plan, scene_xml, model_xml), files),
        lambda: sample_capacities(scene_xml, model_name, model_xml, assets),
        asdict,
        lambda entry: Capacities(**entry),
    )


def sample_capacities(scene_xml: bytes, model_name: str, model_xml: bytes, assets: Path) -> Capacities:
    """Capacities for the batch model ``model_xml`` (file name ``model_name``), meshes under ``assets``."""
    import mujoco

    with tempfile.TemporaryDirectory(prefix="svhdesc-batch-") as tmp:
        # The scene includes the model by file name and the model finds its meshes under assets/.
        (Path(tmp) / model_name).write_bytes(model_xml)
        (Path(tmp) / "scene.xml").write_bytes(scene_xml)
        (Path(tmp) / "assets").symlink_to(assets.resolve(), target_is_directory=True)
        model = mujoco.MjModel.from_xml_path(str(Path(tmp) / "scene.xml"))
    data = mujoco.MjData(model)
    home = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_KEY, "home")
    steps = int(round(ROLLOUT_S / model.opt.timestep))
    pairs = collision_pairs(model)
    worst_ncon = worst_nefc = worst_candidates = 0
    xpos, xmat = np.empty((steps, model.ngeom, 3)), np.empty((steps, model.ngeom, 9))
    body_xpos, body_xmat = np.empty((steps, model.nbody, 3)), np.empty((steps, model.nbody, 9))
    for target in _targets(model):
        if home >= 0:
            mujoco.mj_resetDataKeyframe(model, data, home)
        else:
            mujoco.mj_resetData(model, data)
        data.ctrl[:] = target
        for step in range(steps):
            mujoco.mj_step(model, data)
            worst_ncon = max(worst_ncon, int(data.ncon))
            worst_nefc = max(worst_nefc, int(data.nefc))
            xpos[step], xmat[step] = data.geom_xpos, data.geom_xmat
            body_xpos[step], body_xmat[step] = data.xpos, data.xmat
        # The broadphase of the whole rollout at once, in chunks that keep the arrays small.
        for first in range(0, steps, CHUNK):
            chunk = slice(first, first + CHUNK)
            frames = (body_xpos[chunk], body_xmat[chunk])
            counts = broadphase_candidates(model, xpos[chunk], xmat[chunk], frames, pairs)
            worst_candidates = max(worst_candidates, int(counts.max(initial=0)))
    return Capacities.from_worst_case(worst_ncon, worst_candidates, worst_nefc)
