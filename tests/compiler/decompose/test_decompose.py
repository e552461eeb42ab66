"""Convex decomposition + hull cache.  Small synthetic meshes and cheap CoACD settings keep this fast."""

from __future__ import annotations

import concurrent.futures
import json
import shutil
from collections import Counter
from pathlib import Path

import numpy as np
import pytest
import trimesh

import svhdesc.compiler.decompose as dec
from svhdesc.compiler.decompose import DecompParams, HullCache, cached_decompose, decompose, parallel_decompose
from svhdesc.core.source.meshes import STL_HEADER, stl_bytes
from tests.support import REPO

# Cheap settings: the test meshes are watertight, so CoACD's manifold remesh can be skipped.
FAST = DecompParams(
    threshold=0.05,
    max_convex_hull=-1,
    preprocess_mode="off",
    resolution=1000,
    mcts_nodes=10,
    mcts_iterations=30,
    mcts_max_depth=2,
    max_hull_vertices=64,
)


def _l_shape() -> trimesh.Trimesh:
    """An L-shaped prism (12 vertices, 20 faces): concave, exactly two convex pieces."""
    outline = np.array([[0, 0], [4, 0], [4, 1], [1, 1], [1, 4], [0, 4]], dtype=float) * 0.01
    return trimesh.creation.extrude_triangulation(
        outline, np.array([[0, 1, 2], [0, 2, 3], [0, 3, 4], [0, 4, 5]]), height=0.01
    )


@pytest.fixture(scope="module")
def l_shape() -> trimesh.Trimesh:
    mesh = _l_shape()
    assert mesh.is_watertight and mesh.is_volume
    return mesh


@pytest.fixture(scope="module")
def annulus() -> trimesh.Trimesh:
    mesh = trimesh.creation.annulus(r_min=0.01, r_max=0.02, height=0.01, sections=16)
    assert mesh.is_watertight and mesh.is_volume
    return mesh


def _blobs(hulls: list[trimesh.Trimesh]) -> list[bytes]:
    return [stl_bytes(h) for h in hulls]


def _entry(cache: HullCache, mesh: trimesh.Trimesh, params: DecompParams) -> Path:
    return cache.path(cache.key(mesh, params))


# --------------------------------------------------------------------------- parameters


def test_from_mapping_rejects_unknown_key() -> None:
    with pytest.raises(ValueError, match="max_hulls"):
        DecompParams.from_mapping({"threshold": 0.1, "max_hulls": 4})


def test_from_mapping_overrides_and_normalises() -> None:
    p = DecompParams.from_mapping({"threshold": 1, "max_convex_hull": 4})
    assert p.threshold == 1.0 and isinstance(p.threshold, float)
    assert p.max_convex_hull == 4
    assert p.mcts_iterations == DecompParams().mcts_iterations
    # 1 and 1.0 must not produce different cache keys.
    assert p.to_json() == DecompParams(threshold=1.0, max_convex_hull=4).to_json()
    base = DecompParams(seed=7)
    assert DecompParams.from_mapping({"threshold": 0.2}, base=base).seed == 7


@pytest.mark.parametrize(
    "bad",
    [
        {"threshold": 0.0},
        {"threshold": "0.1"},
        {"max_convex_hull": 0},
        {"max_hull_vertices": 3},
        {"mcts_iterations": 2.5},
        {"seed": True},
        {"preprocess_mode": "sometimes"},
    ],
)
def test_invalid_values_rejected(bad: dict) -> None:
    with pytest.raises(ValueError, match=next(iter(bad))):
        DecompParams.from_mapping(bad)


# --------------------------------------------------------------------------- decomposition


def test_hulls_convex_and_cover(l_shape: trimesh.Trimesh, annulus: trimesh.Trimesh) -> None:
    for mesh in (l_shape, annulus):
        hulls = decompose(mesh, FAST)
        assert len(hulls) >= 2  # both shapes are concave
        for h in hulls:
            assert h.is_convex
            assert h.volume > 0  # outward winding
        # Hulls cover the shape: points sampled inside the mesh lie inside some hull.
        pts = np.random.default_rng(0).uniform(*mesh.bounds, size=(4000, 3))
        pts = pts[mesh.contains(pts)]
        inside = np.zeros(len(pts), bool)
        for h in hulls:
            signed = np.einsum("pfi,fi->pf", pts[:, None] - h.triangles[:, 0], h.face_normals)
            inside |= np.all(signed <= 1e-9, axis=1)
        assert inside.mean() > 0.97


def test_deterministic_order_and_bytes(annulus: trimesh.Trimesh) -> None:
    a = _blobs(decompose(annulus, FAST))
    b = _blobs(decompose(annulus, FAST))
    assert a == b
    centroids = [tuple(np.round(dec._mesh_from_stl(x).center_mass, 9)) for x in a]
    assert centroids == sorted(centroids)


def test_hull_cap_honoured(annulus: trimesh.Trimesh) -> None:
    hulls = decompose(annulus, DecompParams.from_mapping({**_fast(), "max_convex_hull": 2}))
    assert 1 <= len(hulls) <= 2
    assert all(h.is_convex for h in hulls)


def test_merge_fallback_respects_cap(annulus: trimesh.Trimesh) -> None:
    # CoACD normally honours the cap itself; the greedy fallback must too.
    hulls = decompose(annulus, FAST)
    assert len(hulls) > 3
    merged = dec._merge_to_cap(hulls, 3, 64)
    assert len(merged) == 3
    assert all(h.is_convex for h in merged)


def test_vertex_bound_honoured(annulus: trimesh.Trimesh) -> None:
    hulls = decompose(annulus, DecompParams.from_mapping({**_fast(), "max_hull_vertices": 6}))
    assert all(len(h.vertices) <= 6 and h.is_convex for h in hulls)


def test_vertex_bound_fallback_is_deterministic() -> None:
    # The farthest-point fallback, independent of CoACD's own decimation.
    points = trimesh.creation.icosphere(subdivisions=2, radius=0.01).vertices
    a = dec._hull(points, 12)
    b = dec._hull(points, 12)
    assert a is not None and b is not None
    assert len(a.vertices) <= 12 and a.is_convex
    assert stl_bytes(a) == stl_bytes(b)
    # Flat input has no hull worth simulating.
    assert dec._hull(np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0]], float), 12) is None


def test_close_holes_caps_open_boundaries() -> None:
    box = trimesh.creation.box((0.02, 0.01, 0.01))
    side = list(box.facets[0])  # the two triangles of one side
    for drop in (side[:1], side):  # a triangular hole, then a whole square side
        keep = np.setdiff1d(np.arange(len(box.faces)), drop)
        opened = trimesh.Trimesh(box.vertices, box.faces[keep], process=False)
        assert not opened.is_watertight
        vertices, faces = dec._close_holes(np.asarray(opened.vertices), np.asarray(opened.faces))
        closed = trimesh.Trimesh(vertices, faces, process=False)
        assert closed.is_watertight and closed.is_winding_consistent
        assert closed.volume == pytest.approx(box.volume)
    # a closed mesh passes through untouched
    vertices, faces = dec._close_holes(np.asarray(box.vertices), np.asarray(box.faces))
    assert np.array_equal(faces, box.faces) and len(vertices) == len(box.vertices)


def test_open_mesh_is_decomposed_as_a_solid() -> None:
    # A box with one side missing: hulls must fill it, not line its walls.
    box = trimesh.creation.box((0.03, 0.01, 0.01))
    keep = np.setdiff1d(np.arange(len(box.faces)), box.facets[0])
    opened = trimesh.Trimesh(box.vertices, box.faces[keep], process=False)
    assert not opened.is_watertight
    hulls = decompose(opened, DecompParams.from_mapping({**_fast(), "preprocess_mode": "auto"}))
    assert sum(h.volume for h in hulls) == pytest.approx(box.volume, rel=0.05)


def test_stl_roundtrip_is_exact(annulus: trimesh.Trimesh) -> None:
    data = stl_bytes(annulus)
    assert data[:80] == STL_HEADER and len(data) == 84 + 50 * len(annulus.faces)
    again = dec._mesh_from_stl(data)
    assert again.is_watertight and stl_bytes(again) == data
    with pytest.raises(ValueError):
        dec._mesh_from_stl(data[:-1])


def test_key_ignores_vertex_indexing(l_shape: trimesh.Trimesh) -> None:
    # Same triangles with unmerged corners: same content, same key, same hulls.
    soup = trimesh.Trimesh(
        l_shape.triangles.reshape(-1, 3), np.arange(3 * len(l_shape.faces)).reshape(-1, 3), process=False
    )
    assert dec.cache_key(soup, FAST) == dec.cache_key(l_shape, FAST)
    assert _blobs(decompose(soup, FAST)) == _blobs(decompose(l_shape, FAST))


def test_key_depends_on_coacd_version(l_shape: trimesh.Trimesh, monkeypatch: pytest.MonkeyPatch) -> None:
    before = dec.cache_key(l_shape, FAST)
    monkeypatch.setattr(dec.keys, "_coacd_version", lambda: "99.0")
    assert dec.cache_key(l_shape, FAST) != before


# --------------------------------------------------------------------------- cache


def test_cache_hit_runs_no_decomposition(tmp_path: Path, l_shape: trimesh.Trimesh) -> None:
    cache, runs = HullCache(tmp_path), Counter()
    first, hit = cached_decompose(l_shape, FAST, cache, stats=runs)
    assert not hit and runs["decomposed"] == 1
    second, hit = cached_decompose(l_shape, FAST, cache, stats=runs)
    assert hit and runs["decomposed"] == 1
    assert _blobs(first) == _blobs(second)
    entry = json.loads((_entry(cache, l_shape, FAST) / "entry.json").read_text())
    assert entry["count"] == len(first)
    # force recomputes (and rewrites) even on a valid entry
    third, hit = cached_decompose(l_shape, FAST, cache, force=True, stats=runs)
    assert not hit and runs["decomposed"] == 2 and _blobs(third) == _blobs(first)
    assert cached_decompose(l_shape, FAST, cache)[1]


def test_parameter_change_misses(tmp_path: Path, l_shape: trimesh.Trimesh) -> None:
    cache = HullCache(tmp_path)
    other = DecompParams.from_mapping({**_fast(), "threshold": 0.2})
    assert cached_decompose(l_shape, FAST, cache)[1] is False
    runs = Counter()
    assert cached_decompose(l_shape, other, cache, stats=runs)[1] is False
    assert runs["decomposed"] == 1
    assert len([p for p in tmp_path.iterdir() if not p.name.startswith(".")]) == 2
    assert cached_decompose(l_shape, other, cache)[1] is True


def _corrupt_truncate(entry: Path) -> None:
    hull = entry / "hull_000.stl"
    hull.write_bytes(hull.read_bytes()[:100])


def _corrupt_hash(entry: Path) -> None:
    meta = json.loads((entry / "entry.json").read_text())
    meta["files"][0]["sha256"] = "0" * 64
    (entry / "entry.json").write_text(json.dumps(meta))


def _corrupt_count(entry: Path) -> None:
    meta = json.loads((entry / "entry.json").read_text())
    meta["count"] += 1
    (entry / "entry.json").write_text(json.dumps(meta))


def _corrupt_json(entry: Path) -> None:
    (entry / "entry.json").write_text('{"format": 1, "files": [')


def _remove_hull(entry: Path) -> None:
    sorted(entry.glob("hull_*.stl"))[-1].unlink()


def _remove_entry_json(entry: Path) -> None:
    (entry / "entry.json").unlink()


@pytest.mark.parametrize(
    "damage",
    [_corrupt_truncate, _corrupt_hash, _corrupt_count, _corrupt_json, _remove_hull, _remove_entry_json],
)
def test_damaged_entry_is_rebuilt(tmp_path: Path, l_shape: trimesh.Trimesh, damage) -> None:
    cache = HullCache(tmp_path)
    good, _ = cached_decompose(l_shape, FAST, cache)
    entry = _entry(cache, l_shape, FAST)
    damage(entry)
    with pytest.warns(dec.CacheWarning, match="decomposing again") as caught:
        assert cache.get(cache.key(l_shape, FAST)) is None
    assert len(caught) == 1  # one line per entry
    assert not entry.exists()  # deleted, not left to fail again
    runs = Counter()
    rebuilt, hit = cached_decompose(l_shape, FAST, cache, stats=runs)
    assert not hit and runs["decomposed"] == 1
    assert _blobs(rebuilt) == _blobs(good)
    assert cached_decompose(l_shape, FAST, cache)[1]


def _forge_from_other(cache: HullCache, entry: Path, other: Path) -> None:
    """Another entry's files in this entry's place (its entry.json names the other key)."""
    shutil.rmtree(entry)
    shutil.copytree(other, entry)


def _forge_consistently(cache: HullCache, entry: Path, other: Path) -> None:
    """Another entry's hulls with this entry's key and their own digests: every digest in entry.json matches."""
    _forge_from_other(cache, entry, other)
    meta = json.loads((entry / "entry.json").read_text())
    meta["key"] = entry.name
    (entry / "entry.json").write_text(json.dumps(meta))


def _extra_file(cache: HullCache, entry: Path, other: Path) -> None:
    (entry / "hull_099.stl").write_bytes((entry / "hull_000.stl").read_bytes())


@pytest.mark.parametrize(
    ("forge", "problem"),
    [
        (_forge_from_other, "another key"),
        (_forge_consistently, "the mesh uncovered|beyond the mesh.s convex hull"),
        (_extra_file, "extra file"),
    ],
)
@pytest.mark.slow
def test_forged_or_extended_entry_is_never_used(
    tmp_path: Path, l_shape: trimesh.Trimesh, annulus: trimesh.Trimesh, forge, problem: str
) -> None:
    """An entry holding what its key's decomposition is not is one warning and decomposed again (seeded fault: any
    of the entry checks removed from HullCache, and the forged hulls come back as a hit)."""
    cache = HullCache(tmp_path)
    good, _ = cached_decompose(l_shape, FAST, cache)
    cached_decompose(annulus, FAST, cache)
    forge(cache, _entry(cache, l_shape, FAST), _entry(cache, annulus, FAST))
    runs = Counter()
    with pytest.warns(dec.CacheWarning, match=problem) as caught:
        rebuilt, hit = cached_decompose(l_shape, FAST, cache, stats=runs)
    assert len(caught) == 1
    assert not hit and runs["decomposed"] == 1
    assert _blobs(rebuilt) == _blobs(good)
    assert sorted(p.name for p in _entry(cache, l_shape, FAST).iterdir()) == sorted(
        ["entry.json", *(f"hull_{i:03d}.stl" for i in range(len(good)))]
    )  # healed: the extra file went with the entry
    assert cached_decompose(l_shape, FAST, cache)[1]


def test_put_replaces_atomically(tmp_path: Path) -> None:
    cache = HullCache(tmp_path / "cache")
    key = "ab" * 32
    assert cache.get(key) is None
    cache.put(key, [b"one", b"two"])
    assert cache.get(key) == [b"one", b"two"]
    cache.put(key, [b"three"])
    assert cache.get(key) == [b"three"]
    assert [p.name for p in (tmp_path / "cache").iterdir()] == [key]  # no temp dirs left behind
    with pytest.raises(ValueError):
        cache.put(key, [])
    with pytest.raises(ValueError):
        cache.get("../escape")


# --------------------------------------------------------------------------- parallel


@pytest.mark.slow
def test_parallel_equals_serial(tmp_path: Path, l_shape: trimesh.Trimesh, annulus: trimesh.Trimesh) -> None:
    coarse = DecompParams.from_mapping({**_fast(), "threshold": 0.2, "max_convex_hull": 3})
    jobs = [
        ("l", l_shape, FAST),
        ("ring", annulus, FAST),
        ("ring_coarse", annulus, coarse),
        ("l_again", l_shape.copy(), FAST),  # same key as "l": decomposed once
    ]
    serial = {name: _blobs(decompose(mesh, p)) for name, mesh, p in jobs}

    cache = HullCache(tmp_path)
    runs = Counter()
    par = parallel_decompose(jobs, cache, n_jobs=2, stats=runs)
    assert list(par) == [name for name, _, _ in jobs]
    assert runs["decomposed"] == 3
    assert {n: _blobs(h) for n, (h, _) in par.items()} == serial
    assert not any(hit for _, hit in par.values())

    one = parallel_decompose(jobs, None, n_jobs=1)
    assert {n: _blobs(h) for n, (h, _) in one.items()} == serial


def test_parallel_hits_spawn_nothing(
    tmp_path: Path, l_shape: trimesh.Trimesh, annulus: trimesh.Trimesh, monkeypatch: pytest.MonkeyPatch
) -> None:
    cache = HullCache(tmp_path)
    jobs = [("l", l_shape, FAST), ("ring", annulus, FAST)]
    first = parallel_decompose(jobs, cache, n_jobs=1)

    def no_pool(*args: object, **kwargs: object) -> None:
        raise AssertionError("a process pool was started for cache hits")

    monkeypatch.setattr(concurrent.futures, "ProcessPoolExecutor", no_pool)
    runs = Counter()
    again = parallel_decompose(jobs, cache, n_jobs=2, progress=True, stats=runs)
    assert runs["decomposed"] == 0
    assert all(hit for _, hit in again.values())
    assert {n: _blobs(h) for n, (h, _) in again.items()} == {n: _blobs(h) for n, (h, _) in first.items()}


def test_parallel_rejects_duplicate_names(l_shape: trimesh.Trimesh) -> None:
    with pytest.raises(ValueError, match="duplicate"):
        parallel_decompose([("a", l_shape, FAST), ("a", l_shape, FAST)], None, n_jobs=1)


SVH_MESHES = REPO.parent / "shared" / "vendor" / "schunk_svh_driver" / "description" / "meshes"


@pytest.mark.skipif(not SVH_MESHES.is_dir(), reason="vendor meshes (../shared) not present")
def test_vendor_phalanx_with_preset() -> None:
    # f11 is open (mm-size holes): hole closing makes it a solid CoACD can cut without remeshing.
    from svhdesc.core.source.meshes import load_mesh

    mesh = load_mesh(SVH_MESHES / "f11.dae")
    assert not mesh.is_watertight
    params = dec.LINK_CLASS_PARAMS["phalanx"]
    hulls = decompose(mesh, params)
    assert 1 <= len(hulls) <= params.max_convex_hull
    assert all(h.is_convex and len(h.vertices) <= params.max_hull_vertices for h in hulls)
    # The hulls hug the surface: nearly every surface point lies within 1 mm of the hull set.
    points, _ = trimesh.sample.sample_surface(mesh, 2000, seed=0)
    gap = np.min(
        [np.einsum("pfi,fi->pf", points[:, None] - h.triangles[:, 0], h.face_normals).max(axis=1) for h in hulls],
        axis=0,
    )
    assert np.mean(gap <= 1e-3) > 0.95, np.mean(gap <= 1e-3)


def _fast() -> dict:
    return json.loads(FAST.to_json())
