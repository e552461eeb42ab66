"""svhdesc.core.source.meshes: loading, canonical STL, hulls, cylinder fits; the authored meshes."""

from __future__ import annotations

import io
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import trimesh
from scipy.spatial import cKDTree

from svhdesc.compiler.pipeline.agreement import file_difference
from svhdesc.core.source.meshes import (
    MeshError,
    convex_hull,
    load_mesh,
    mesh_volume,
    obj_bytes,
    principal_cylinder,
    stl_bytes,
)
from tests.support import REPO

SHARED = REPO.parent / "shared"
SVH_MESHES = SHARED / "vendor" / "schunk_svh_driver" / "description" / "meshes"
AUTHORED = REPO / "meshes"

needs_vendor = pytest.mark.skipif(not SVH_MESHES.is_dir(), reason="vendor meshes (../shared) not present")


def _l_shape() -> trimesh.Trimesh:
    """A closed, non-convex, asymmetric solid (two boxes welded into an L)."""
    a = trimesh.creation.box((0.04, 0.01, 0.01), transform=trimesh.transformations.translation_matrix((0.02, 0, 0)))
    b = trimesh.creation.box((0.01, 0.03, 0.01), transform=trimesh.transformations.translation_matrix((0, 0.015, 0)))
    return trimesh.boolean.union([a, b], engine="manifold")


def _shuffled(mesh: trimesh.Trimesh, seed: int = 0) -> trimesh.Trimesh:
    """The same triangles with permuted vertices, permuted faces and rotated corners."""
    rng = np.random.default_rng(seed)
    perm = rng.permutation(len(mesh.vertices))
    inverse = np.argsort(perm)
    faces = inverse[np.asarray(mesh.faces)]
    faces = np.array([np.roll(f, int(k)) for f, k in zip(faces, rng.integers(0, 3, len(faces)), strict=True)])
    faces = faces[rng.permutation(len(faces))]
    return trimesh.Trimesh(np.asarray(mesh.vertices)[perm], faces, process=False)


# ----------------------------------------------------------------------------- load_mesh


@needs_vendor
def test_vendor_dae_split_per_material_is_watertight_only_after_merging():
    path = SVH_MESHES / "f13.dae"  # fingertip: three material groups
    raw = trimesh.load(str(path), force="mesh", process=False)
    assert not trimesh.Trimesh(raw.vertices, raw.faces, process=False).is_watertight
    mesh = load_mesh(path)
    assert mesh.is_watertight and mesh.is_winding_consistent
    assert len(mesh.vertices) < len(raw.vertices)
    assert mesh.volume > 0


@needs_vendor
def test_vendor_h10_scene_transform_baked_and_winding_fixed():
    # h10's only node scales its geometry by 0.014; the palm is ~67 x 59 x 121.5 mm.
    # (It stays open after merging: the vendor mesh has real holes, up to ~8 mm across.)
    mesh = load_mesh(SVH_MESHES / "h10.dae")
    np.testing.assert_allclose(mesh.extents, [0.06713, 0.05923, 0.1215], atol=2e-4)
    assert mesh.is_winding_consistent
    assert len(mesh.faces) > 1000


def test_collada_unit_and_up_axis_are_respected(tmp_path: Path):
    source = (AUTHORED / "svh" / "z.dae").read_bytes()  # no vertices within 1 mm of each other at its extremes
    reference = load_mesh(AUTHORED / "svh" / "z.dae")
    mm = tmp_path / "mm.dae"
    mm.write_bytes(source.replace(b'meter="1"', b'meter="0.001"'))
    np.testing.assert_allclose(load_mesh(mm).bounds, reference.bounds * 1e-3, atol=1e-12)
    y_up = tmp_path / "yup.dae"
    y_up.write_bytes(source.replace(b"<up_axis>Z_UP</up_axis>", b"<up_axis>Y_UP</up_axis>"))
    (x0, y0, z0), (x1, y1, z1) = reference.bounds
    np.testing.assert_allclose(load_mesh(y_up).bounds, [[x0, -z1, y0], [x1, -z0, y1]], atol=1e-12)


@pytest.mark.parametrize("scale", [(-1.0, 1.0, 1.0), (1.0, -1.0, -1.0), (1.0, 1.0, -2.0)])
def test_negative_scale_mirrors_and_keeps_volume_positive(tmp_path: Path, scale):
    path = tmp_path / "l.stl"
    path.write_bytes(stl_bytes(_l_shape()))
    plain = load_mesh(path)
    scaled = load_mesh(path, scale)
    s = np.asarray(scale)
    np.testing.assert_allclose(np.sort(scaled.vertices, axis=0), np.sort(plain.vertices * s, axis=0))
    assert scaled.is_watertight
    assert scaled.volume > 0
    assert scaled.volume == pytest.approx(plain.volume * abs(np.prod(s)), rel=1e-9)
    # outward normals: the centroid of every face plus a small step along its normal lies outside
    probe = scaled.triangles_center + 1e-5 * scaled.face_normals
    assert not scaled.contains(probe).any()


def test_mirrored_authored_mesh_keeps_volume(tmp_path: Path):
    plain = load_mesh(AUTHORED / "svh" / "e1.dae")
    mirrored = load_mesh(AUTHORED / "svh" / "e1.dae", (-1.0, 1.0, 1.0))
    assert mirrored.volume == pytest.approx(plain.volume, rel=1e-9) and mirrored.volume > 0
    np.testing.assert_allclose(mirrored.bounds[:, 0], -plain.bounds[::-1, 0])


def test_missing_file_raises_mesh_error_naming_the_path(tmp_path: Path):
    missing = tmp_path / "nowhere" / "gone.dae"
    with pytest.raises(MeshError, match="gone.dae") as info:
        load_mesh(missing)
    assert str(missing) in str(info.value)
    assert isinstance(info.value, ValueError)


@pytest.mark.parametrize(
    ("name", "data"),
    [
        ("broken.dae", b"<COLLADA><asset>"),
        ("empty.stl", b"solid empty\nendsolid empty\n"),
        ("garbage.obj", b"\x00\x01 not an obj"),
        ("mesh.ply", b"ply\n"),
    ],
)
def test_unreadable_or_empty_file_raises_mesh_error(tmp_path: Path, name: str, data: bytes):
    path = tmp_path / name
    path.write_bytes(data)
    with pytest.raises(MeshError, match=name):
        load_mesh(path)


# ----------------------------------------------------------------------------- stl_bytes


def test_stl_bytes_deterministic_and_canonical():
    mesh = _l_shape()
    data = stl_bytes(mesh)
    assert data == stl_bytes(mesh.copy())
    assert data == stl_bytes(_shuffled(mesh, 1)) == stl_bytes(_shuffled(mesh, 2))
    assert data[:80] == stl_bytes(trimesh.creation.icosphere())[:80]  # fixed header, no timestamp
    assert len(data) == 84 + 50 * len(mesh.faces)


def test_stl_bytes_round_trip():
    mesh = _l_shape()
    back = trimesh.load(io.BytesIO(stl_bytes(mesh)), file_type="stl")
    assert len(back.faces) == len(mesh.faces)
    assert back.is_watertight
    assert back.volume == pytest.approx(mesh.volume, rel=1e-6)
    np.testing.assert_allclose(back.bounds, mesh.bounds, atol=1e-7)


# ----------------------------------------------------------------------------- hull, volume, cylinder


def test_convex_hull_is_convex_closed_and_order_independent():
    mesh = _l_shape()
    hull = convex_hull(mesh)
    assert hull.is_convex and hull.is_watertight and hull.volume > mesh.volume
    assert stl_bytes(hull) == stl_bytes(convex_hull(_shuffled(mesh, 3)))


def test_convex_hull_of_flat_input_raises():
    flat = trimesh.Trimesh([[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0]], [[0, 1, 2], [1, 3, 2]], process=False)
    with pytest.raises(MeshError, match="degenerate"):
        convex_hull(flat)


def test_mesh_volume_closed_and_open():
    mesh = _l_shape()
    assert mesh_volume(mesh) == pytest.approx(0.04 * 0.01 * 0.01 + 0.01 * 0.03 * 0.01 - 0.005 * 0.005 * 0.01)
    open_box = trimesh.creation.box((0.01, 0.02, 0.03))
    open_box.update_faces(np.arange(len(open_box.faces)) > 1)
    assert mesh_volume(open_box) == pytest.approx(0.01 * 0.02 * 0.03)


def test_principal_cylinder_recovers_a_cylinder():
    radius, height = 0.015, 0.12
    rotation = trimesh.transformations.rotation_matrix(0.7, (1.0, 2.0, -0.5))
    transform = trimesh.transformations.translation_matrix((0.1, -0.2, 0.3)) @ rotation
    cylinder = trimesh.creation.cylinder(radius=radius, height=height, sections=128, transform=transform)
    centre, axis, r, length = principal_cylinder(cylinder)
    expected_axis = rotation[:3, 2] * np.sign(rotation[:3, 2][np.argmax(np.abs(rotation[:3, 2]))])
    np.testing.assert_allclose(axis, expected_axis, atol=1e-9)
    assert np.linalg.norm(axis) == pytest.approx(1.0)
    assert axis[np.argmax(np.abs(axis))] > 0  # sign convention
    np.testing.assert_allclose(centre, [0.1, -0.2, 0.3], atol=1e-9)
    assert r == pytest.approx(radius, rel=1e-3)
    assert length == pytest.approx(height, rel=1e-9)


def test_principal_cylinder_of_a_box_is_along_its_long_side():
    centre, axis, r, length = principal_cylinder(trimesh.creation.box((0.02, 0.1, 0.04)))
    np.testing.assert_allclose(axis, [0, 1, 0], atol=1e-12)
    assert length == pytest.approx(0.1)
    # same moment about the axis as the box: r^2 / 2 = (a^2 + b^2) / 12
    assert r == pytest.approx(np.sqrt((0.02**2 + 0.04**2) / 6))


# ----------------------------------------------------------------------------- authored meshes

AUTHORED_FILES = sorted(AUTHORED.glob("*/*.dae"))
# mirror under which each finger mesh must be invariant (the left hand reuses them unscaled)
SYMMETRY = {"virtual_l": 1, "virtual_k": 1, "virtual_j": 1, "virtual_i": 1} | {
    k: 2 for k in ("a", "b", "c", "l", "p", "t", "k", "o", "s", "j", "n", "r", "i", "m", "q")
}


def test_every_link_has_an_authored_mesh():
    svh = {p.stem for p in (AUTHORED / "svh").glob("*.dae")}
    ur5 = {p.stem for p in (AUTHORED / "ur5").glob("*.dae")}
    assert svh == {"base_link", "e1", "e2", "z"} | set(SYMMETRY)
    assert ur5 == {"base", "shoulder", "upper_arm", "forearm", "wrist_1", "wrist_2", "wrist_3"}


@pytest.mark.parametrize("path", AUTHORED_FILES, ids=lambda p: f"{p.parent.name}/{p.stem}")
def test_authored_mesh_is_closed_light_and_symmetric(path: Path):
    raw = trimesh.load(str(path), force="mesh")
    assert raw.is_watertight  # closed as stored, not only after welding
    mesh = load_mesh(path)
    assert mesh.is_watertight and mesh.volume > 0
    assert len(mesh.split(only_watertight=False)) == 1
    # up to 15000: clipping to the slices of the vendor parts (tools/slice_solid.py) adds facets
    assert 200 <= len(mesh.faces) <= 15000
    axis = SYMMETRY.get(path.stem) if path.parent.name == "svh" else None
    if axis is not None:
        mirrored = np.array(mesh.vertices)
        mirrored[:, axis] *= -1
        distance, _ = cKDTree(mesh.vertices).query(mirrored)
        assert distance.max() < 1e-9


@pytest.mark.slow
def test_authoring_script_reproduces_the_committed_meshes(tmp_path: Path):
    result = subprocess.run(
        [sys.executable, str(REPO / "tools" / "author_meshes.py"), "--out", str(tmp_path)],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert result.returncode == 0, result.stderr
    for path in AUTHORED_FILES:
        fresh = tmp_path / path.parent.name / path.name
        assert file_difference(fresh, path) is None, f"{path.relative_to(REPO)} differs from the script's output"


def test_obj_bytes_canonical_and_exact_float32_corners():
    mesh = _l_shape()
    data = obj_bytes(mesh)
    assert data == obj_bytes(_shuffled(mesh, 1)) == obj_bytes(_shuffled(mesh, 2))
    back = trimesh.load(io.BytesIO(data), file_type="obj", process=False)
    assert len(back.faces) == len(mesh.faces) and back.is_watertight
    assert back.volume == pytest.approx(mesh.volume, rel=1e-6)  # winding kept: outward normals
    # Read as float64, the corners are exactly the float32 corners the STL stores.
    stl = trimesh.load(io.BytesIO(stl_bytes(mesh)), file_type="stl", process=False)
    corners = np.asarray(back.vertices)[np.asarray(back.faces)].reshape(-1, 3)
    assert np.array_equal(np.unique(corners, axis=0), np.unique(np.asarray(stl.vertices), axis=0))
