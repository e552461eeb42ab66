"""Which link pairs a planner may skip, computed as MoveIt's Setup Assistant does.

Reasons, in the Setup Assistant's order: ``Adjacent`` (parent and child, looking through links
without collision geometry), ``Default`` (touching in the zero pose), ``Always`` (touching in at
least 95 % of random poses) and ``Never``. Poses draw every actuated joint uniformly within its
limits; coupled joints follow the spec, as MoveIt's mimic joints do. Collisions come from MuJoCo on
the build's own MJCF, with every contact exclusion and the parent-child filter lifted; a fixed seed
keeps the result deterministic.

``Never`` is stricter than the Setup Assistant's "no collision in any sample": the pair must never
come within ``NEAR`` of each other. Random sampling misses rare poses (the hand folded back onto the
arm's base collides in about 1 of 1000); poses that come close to them are far more common, so a
pair sampled near-but-apart stays checked.
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np

from svhdesc.compiler.assets import Assets
from svhdesc.compiler.probes.cache import cache_dir, content_key, remembered
from svhdesc.ir import Robot

SAMPLES = 5000  # the Setup Assistant draws 10000; with the NEAR rule 2000 gave the same matrix
SEED = 0
ALWAYS_FRACTION = 0.95
NEAR = 0.01  # m
ROUND = 500  # samples between recompiles that leave out the pairs settled so far


def adjacent_links(robot: Robot) -> set[tuple[str, str]]:
    """(parent, child) pairs of links with collision geometry, looking through links without."""
    parent_of = {j.child: j.parent for j in robot.joints}
    colliding = {link.name for link in robot.links if link.collisions}
    pairs = set()
    for name in colliding:
        ancestor = parent_of.get(name)
        while ancestor is not None and ancestor not in colliding:
            ancestor = parent_of.get(ancestor)
        if ancestor is not None:
            pairs.add((ancestor, name))
    return pairs


def _probe(model: Any, data: Any, mujoco: Any) -> tuple[set[tuple[int, int]], set[tuple[int, int]]]:
    """Body pairs (touching, closer than NEAR) in the pose in ``data.qpos``."""
    mujoco.mj_kinematics(model, data)
    mujoco.mj_collision(model, data)
    contacts = data.contact
    bodies = np.sort(model.geom_bodyid[contacts.geom[: data.ncon]], axis=1)
    touching = bodies[contacts.dist[: data.ncon] < 0.0]
    return {(int(a), int(b)) for a, b in touching}, {(int(a), int(b)) for a, b in bodies}


def _sample(
    robot: Robot,
    model: Any,
    data: Any,
    samples: int,
    rng: np.random.Generator,
    found: tuple[dict[tuple[int, int], int], set[tuple[int, int]]],
) -> None:
    """Over ``samples`` random postures (actuated joints uniform in their limits, coupled ones following), drawn
    from ``rng``: how often each body pair touches, and every pair that comes near, added to ``found``."""
    import mujoco

    joints = {j.name: j for j in robot.joints}
    actuated = [a.joint for a in robot.actuators]
    coupled = [(j.name, j.mimic.joint, j.mimic.coeffs) for j in robot.joints if j.mimic]
    address = {name: model.joint(name).qposadr[0] for name in actuated + [c[0] for c in coupled]}
    low = np.array([joints[n].lower for n in actuated])
    high = np.array([joints[n].upper for n in actuated])
    touching, near = found
    for _ in range(samples):
        values = dict(zip(actuated, rng.uniform(low, high)))
        for name, follows, coeffs in coupled:
            values[name] = sum(c * values[follows] ** k for k, c in enumerate(coeffs))
        for name, value in values.items():
            data.qpos[address[name]] = value
        hits, close = _probe(model, data, mujoco)
        for pair in hits:
            touching[pair] = touching.get(pair, 0) + 1
        near |= close


def _settled(
    found: tuple[dict[tuple[int, int], int], set[tuple[int, int]]], drawn: int, samples: int
) -> set[tuple[int, int]]:
    """Pairs whose reason no further sample can change: near already, and apart in too many samples to be
    ``Always`` even if they touched in every one left."""
    touching, near = found
    return {pair for pair in near if touching.get(pair, 0) + samples - drawn < ALWAYS_FRACTION * samples}


def collision_matrix(
    robot: Robot, assets: Assets, samples: int = SAMPLES, seed: int = SEED
) -> dict[tuple[str, str], str]:
    """(link, link) -> reason for every pair that need not be checked; pairs in link order."""
    import mujoco

    from svhdesc.compiler.export.mjcf import export_mjcf

    order = {link.name: i for i, link in enumerate(robot.links)}
    colliding = sorted((link.name for link in robot.links if link.collisions), key=order.__getitem__)

    def key(a: str, b: str) -> tuple[str, str]:
        return (a, b) if order[a] < order[b] else (b, a)

    def compiled(excluded: list[tuple[str, str]]) -> tuple[Any, Any]:
        # Pairs already decided are excluded: the samples then only pay for the open ones.
        xml = export_mjcf(replace(robot, excludes=tuple(excluded))).decode()
        model = mujoco.MjModel.from_xml_string(xml, {f"assets/{k}": v for k, v in assets.files.items()})
        model.opt.disableflags |= int(mujoco.mjtDisableBit.mjDSBL_FILTERPARENT)
        model.geom_margin[:] = NEAR  # contacts are generated up to NEAR apart
        return model, mujoco.MjData(model)

    reasons = {key(a, b): "Adjacent" for a, b in adjacent_links(robot)}
    model, data = compiled(list(reasons))
    body = {name: model.body(name).id for name in colliding}
    name_of = {v: k for k, v in body.items()}
    for first, second in _probe(model, data, mujoco)[0]:
        if first in name_of and second in name_of:
            reasons.setdefault(key(name_of[first], name_of[second]), "Default")
    # The samples in rounds, each compiled without the pairs the earlier ones settled: the same draws and the same
    # matrix, without the narrowphase of neighbours that come near in most poses.
    rng, found, drawn = np.random.default_rng(seed), ({}, set()), 0
    touching, near = found
    while drawn < samples:
        settled = [key(name_of[a], name_of[b]) for a, b in _settled(found, drawn, samples) if {a, b} <= name_of.keys()]
        model, data = compiled(sorted(set(reasons) | set(settled)))
        batch = min(ROUND, samples - drawn)
        _sample(robot, model, data, batch, rng, found)
        drawn += batch
    for a in range(len(colliding)):
        for b in range(a + 1, len(colliding)):
            pair_key = key(colliding[a], colliding[b])
            if pair_key in reasons:
                continue
            ids = (min(body[colliding[a]], body[colliding[b]]), max(body[colliding[a]], body[colliding[b]]))
            if ids not in near:
                reasons[pair_key] = "Never"
            elif touching.get(ids, 0) >= ALWAYS_FRACTION * samples:
                reasons[pair_key] = "Always"
    return dict(sorted(reasons.items(), key=lambda item: (order[item[0][0]], order[item[0][1]])))


def cached_collision_matrix(robot: Robot, assets: Assets) -> dict[tuple[str, str], str]:
    """``collision_matrix``, remembered by content (``svhdesc.compiler.probes.cache``): the MJCF states every
    joint, limit, coupling and geom it samples."""
    from svhdesc.compiler.export.mjcf import export_mjcf

    plan = repr((SAMPLES, SEED, NEAR, ALWAYS_FRACTION)).encode() + Path(__file__).read_bytes()  # and this code
    names = repr([link.name for link in robot.links]).encode()  # the order pairs are written in
    return remembered(
        cache_dir("collision_matrix"),
        content_key((plan, names, export_mjcf(robot)), assets.files),
        lambda: collision_matrix(robot, assets),
        lambda matrix: [[a, b, reason] for (a, b), reason in matrix.items()],
        lambda entry: {(a, b): reason for a, b, reason in entry},
    )
