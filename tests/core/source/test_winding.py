"""svhdesc.core.source.winding: the faces trimesh's fix_winding leaves, on real meshes whose winding it changes."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import trimesh

from svhdesc.core.settings.config import resolve_path
from svhdesc.core.source import meshes
from svhdesc.core.source.winding import fix_winding
from tests.support import REPO

ROBOTS = "python:cmeel.prefix/share/example-robot-data/robots"
# Meshes of example-robot-data whose faces disagree once welded: a few flips that make the UR3's wrist consistent,
# and Talos' ankle, where hundreds flip and no orientation is consistent (an edge shared by more than two faces).
MESHES = ("ur_description/meshes/ur3/collision/wrist1.stl", "talos_data/meshes/v2/ankle_Y_lo_res.stl")
VENDOR_H10 = REPO.parent / "shared" / "vendor" / "schunk_svh_driver" / "description" / "meshes" / "h10.dae"


def _welded(path: Path) -> trimesh.Trimesh:
    """The mesh as load_mesh has it just before its winding is fixed."""
    mesh = meshes.welded(meshes._read(path))
    return trimesh.Trimesh(vertices=np.asarray(mesh.vertices), faces=np.asarray(mesh.faces), process=False)


def _paths() -> list[Path]:
    try:
        robots = resolve_path(ROBOTS, REPO, "test")
    except Exception as exc:  # noqa: BLE001 - the wheel is in the test extra; say so if it is missing
        pytest.fail(f"example-robot-data is not installed: {exc}")
    return [robots / m for m in MESHES] + ([VENDOR_H10] if VENDOR_H10.is_file() else [])


def test_the_faces_trimesh_leaves() -> None:
    """Face for face what trimesh.repair.fix_winding gives, where it flips faces (seeded fault: a child's flip
    taken from its shared edge alone, without its parent's -> the UR3 and vendor meshes differ)."""
    for path in _paths():
        theirs, ours = _welded(path), _welded(path)
        before = np.asarray(ours.faces).copy()
        trimesh.repair.fix_winding(theirs)
        fix_winding(ours)
        assert (np.asarray(theirs.faces) != before).any(), f"{path.name}: trimesh flips nothing: not a test"
        np.testing.assert_array_equal(np.asarray(ours.faces), np.asarray(theirs.faces), err_msg=str(path))


def test_a_consistent_mesh_is_left_as_it_is() -> None:
    box = trimesh.creation.box((0.01, 0.02, 0.03))
    faces = np.asarray(box.faces).copy()
    fix_winding(box)
    np.testing.assert_array_equal(np.asarray(box.faces), faces)
