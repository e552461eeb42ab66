"""The fit check every reused hull passes (``svhdesc.compiler.decompose.fit``), on every shipped decomposition, and
the three forged hull-cache entries of issue 38: fingertip ``t`` given the 8 hulls of fingertip ``s``, link ``o``
given the 8 hulls of ``n`` (instead of its 16), and one box over ``z``'s bounds, each with its digests rewritten.

The box is refused. The other two are decompositions of meshes that differ from ``t`` and ``o`` by less than CoACD's
own distance from either, so no check of the hulls against the mesh can refuse them: they are the cache's trust
boundary (docs/build.md), which ``build --check`` does not cross by default
(tests/compiler/pipeline/test_hull_trust.py).
"""

from __future__ import annotations

import json
from functools import cache
from pathlib import Path

import numpy as np
import pytest
import trimesh

from svhdesc.compiler.decompose import CacheWarning, HullCache
from svhdesc.compiler.decompose.fit import COVER_TOLERANCE, misfit_hulls
from svhdesc.compiler.decompose.source import _mesh
from svhdesc.core.source.meshes import load_mesh, stl_bytes
from tests.support import REPO


@cache
def shipped() -> dict[str, tuple[trimesh.Trimesh, list[trimesh.Trimesh]]]:
    """Every decomposition committed in generated/, by its asset stem: (source mesh, hulls)."""
    found = {}
    for manifest in sorted((REPO / "generated").glob("*/manifest.json")):
        for files in json.loads(manifest.read_text())["decompositions"].values():
            stem = files[0].split("_hull_")[0]
            (source,) = (REPO / "meshes").glob(f"*/{stem}.dae")
            hulls = [_mesh((manifest.parent / "assets" / name).read_bytes(), "obj") for name in files]
            found[stem] = (load_mesh(source), hulls)
    return found


def test_every_shipped_decomposition_fits_and_no_box_does() -> None:
    """Each committed decomposition passes; a box over its mesh's bounds and its oriented bounding box do not
    (seeded faults: INSIDE_TOLERANCE raised to 0.2 lets the boxes pass; COVER_TOLERANCE lowered to 0.03 refuses
    virtual_i's own hulls, which leave 4.0 % uncovered)."""
    decompositions = shipped()
    assert len(decompositions) >= 24  # the hand's 21 and the UR5's 3
    misfits = {stem: misfit_hulls(mesh, hulls) for stem, (mesh, hulls) in decompositions.items()}
    assert not any(misfits.values()), misfits
    for stem, (mesh, _) in decompositions.items():
        assert misfit_hulls(mesh, [trimesh.creation.box(bounds=mesh.bounds)]), stem
        assert misfit_hulls(mesh, [mesh.bounding_box_oriented]), stem


def _distance(a: trimesh.Trimesh, b: trimesh.Trimesh) -> float:
    """The symmetric Hausdorff distance between the two meshes' vertices and surfaces, over a's largest extent."""
    _, ab, _ = trimesh.proximity.closest_point(b, a.vertices)
    _, ba, _ = trimesh.proximity.closest_point(a, b.vertices)
    return float(max(ab.max(), ba.max()) / np.max(a.extents))


@pytest.mark.slow  # 552 pairs of a mesh and hulls: about 20 s on 2 busy cores
def test_another_mesh_s_hulls_pass_only_for_a_nearly_identical_mesh() -> None:
    """Of the 552 (mesh, other mesh's hulls) pairs, those that pass are meshes within COVER_TOLERANCE of each other
    (the fingertips q, r, s, t; the proximal phalanges n, o; i, j, k, l): a decomposition of the one is a
    decomposition of the other within CoACD's own error (seeded fault: the cover check removed from misfit_hulls,
    and the palm's hulls pass for a fingertip)."""
    decompositions = shipped()
    passing = [
        (target, donor)
        for target, (mesh, _) in decompositions.items()
        for donor, (_, hulls) in decompositions.items()
        if donor != target and not misfit_hulls(mesh, hulls)
    ]
    assert ("t", "s") in passing and ("o", "n") in passing  # the trust boundary, as docs/build.md says
    far = {
        pair: d
        for pair in passing
        if (d := _distance(decompositions[pair[0]][0], decompositions[pair[1]][0])) > COVER_TOLERANCE
    }
    assert not far, far
    assert len(passing) < 0.05 * len(decompositions) ** 2


def _forge(cache: HullCache, mesh: trimesh.Trimesh, hulls: list[trimesh.Trimesh]) -> str:
    """An entry for ``mesh`` holding ``hulls``, its digests those of the hulls: what rewriting entry.json gives."""
    key = HullCache.key(mesh, _params())
    cache.put(key, [stl_bytes(h) for h in hulls])
    return key


def _params():  # noqa: ANN202
    from svhdesc.compiler.decompose import DecompParams

    return DecompParams(threshold=0.03, max_convex_hull=8)


def test_the_three_forged_entries(tmp_path: Path) -> None:
    """The box over z is refused with one warning and the entry deleted; t with s's hulls and o with n's are served:
    the documented trust boundary (seeded fault: hulls_for without misfit_hulls serves the box)."""
    decompositions = shipped()
    cache = HullCache(tmp_path)
    z = decompositions["z"][0]
    box = _forge(cache, z, [trimesh.creation.box(bounds=z.bounds)])
    with pytest.warns(CacheWarning, match="beyond the mesh's convex hull") as caught:
        assert cache.hulls_for(box, z) is None
    assert len(caught) == 1 and not cache.path(box).exists()
    for target, donor in (("t", "s"), ("o", "n")):
        mesh = decompositions[target][0]
        key = _forge(cache, mesh, decompositions[donor][1])
        served = cache.hulls_for(key, mesh)
        assert served is not None and len(served) == len(decompositions[donor][1])
