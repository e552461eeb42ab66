"""Meshes of 100 MB and of a million triangles through `validate` (both tiers; a URDF in a process as CI runs
it, bounded by 60 s and 4 GiB of address space) and `init` (issue 48 item 9). A mesh file over
``core.limits.MAX_MESH_BYTES`` (64 MB; the biggest robot mesh of 3,226 is 27 MB) is never read: validate's meshes
check names it and the full tier leaves it out, an MJCF naming it is not compiled, init refuses it. A million
triangles (50 MB) is read: the static tier passes, MuJoCo's own limit (200,000 faces in an STL) is the full tier's
finding, and init refuses it by that limit (``core.limits.MAX_MESH_TRIANGLES``: the build took 155 s and 1.9 GB
before MuJoCo refused it; now 7 s). The files are written here cheaply: a sparse 100 MB STL (zeros), and a sphere's
triangles written with numpy.

Seeded faults: no size check in check_meshes (the sparse STL is read, 1.1 GB, and no finding names the limit; before
this change its zero-size visual was a ZeroDivisionError traceback); none in _irregular_assets (MuJoCo opens the
MJCF's 100 MB mesh and refuses it with its own face-count error, which names no size); neither init's size check
in _check_meshes nor the floor's MeshTooBig (a config is written for the mesh the build refuses; either alone
refuses this arm, whose visual and collision are one file).
"""

from __future__ import annotations

import resource
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from tests.support import fails_cleanly, run_cli

ARM = """<?xml version="1.0"?>
<robot name="arm"><link name="base"/>
  <link name="upper"><inertial><mass value="1"/>
    <inertia ixx="0.01" iyy="0.01" izz="0.01" ixy="0" ixz="0" iyz="0"/></inertial>
    <visual><geometry><mesh filename="{mesh}"/></geometry></visual>
    <collision><geometry><mesh filename="{mesh}"/></geometry></collision></link>
  <joint name="j" type="revolute"><parent link="base"/><child link="upper"/><axis xyz="0 1 0"/>
    <limit lower="-1" upper="1" effort="10" velocity="1"/></joint>
</robot>
"""
MJCF = """<mujoco><asset><mesh name="m" file="{mesh}"/></asset>
<worldbody><body><joint type="hinge"/><geom type="mesh" mesh="m"/></body></worldbody></mujoco>
"""


def sphere_stl(path: Path, rings: int, radius: float = 0.05) -> int:
    """A UV sphere of 2 rings^2 triangles as binary STL, written with numpy; the number of triangles."""
    theta, phi = np.meshgrid(np.linspace(0, np.pi, rings + 1), np.linspace(0, 2 * np.pi, rings + 1), indexing="ij")
    points = np.stack([np.sin(theta) * np.cos(phi), np.sin(theta) * np.sin(phi), np.cos(theta)], axis=-1) * radius
    a, b, c, d = points[:-1, :-1], points[1:, :-1], points[1:, 1:], points[:-1, 1:]
    triangles = np.concatenate([np.stack(t, axis=2).reshape(-1, 3, 3) for t in ((a, b, c), (a, c, d))])
    record = np.zeros(len(triangles), dtype=[("normal", "<f4", 3), ("v", "<f4", (3, 3)), ("attr", "<u2")])
    record["v"] = triangles
    with path.open("wb") as stream:
        stream.write(b"\0" * 80 + np.uint32(len(triangles)).tobytes())
        record.tofile(stream)
    return len(triangles)


def sparse_stl(path: Path, size: int) -> None:
    """A binary STL of ``size`` bytes whose triangles are all zeros, written as a sparse file (no disk used)."""
    with path.open("wb") as stream:
        stream.write(b"\0" * 80 + np.uint32((size - 84) // 50).tobytes())
        stream.truncate(84 + 50 * ((size - 84) // 50))


@pytest.fixture(scope="module")
def meshes(tmp_path_factory: pytest.TempPathFactory) -> Path:
    folder = tmp_path_factory.mktemp("big_meshes")
    sparse_stl(folder / "sparse.stl", 100 << 20)
    assert sphere_stl(folder / "million.stl", 708) > 1_000_000
    for name in ("sparse", "million"):
        (folder / f"{name}.urdf").write_text(ARM.format(mesh=f"{name}.stl"))
    (folder / "sparse.xml").write_text(MJCF.format(mesh="sparse.stl"))
    return folder


def _guard() -> None:
    resource.setrlimit(resource.RLIMIT_AS, (4 << 30, 4 << 30))


def _validate(*args: str) -> subprocess.CompletedProcess[str]:
    started = time.perf_counter()
    done = subprocess.run(
        [sys.executable, "-m", "svhdesc.cli", "validate", *args],
        capture_output=True,
        text=True,
        timeout=60,
        preexec_fn=_guard,
    )
    assert time.perf_counter() - started < 60
    assert "Traceback" not in done.stderr, done.stderr[-3000:]
    return done


def test_a_100_mb_mesh_is_not_read(meshes: Path) -> None:
    urdf = _validate(str(meshes / "sparse.urdf"), "--tier", "full")
    assert urdf.returncode == 1, urdf.stdout + urdf.stderr
    assert "sparse.stl is 100 MB, more than the 64 MB svhdesc reads in a mesh file" in urdf.stdout, urdf.stdout
    mjcf = run_cli("validate", str(meshes / "sparse.xml"), "--tier", "static", in_process=True)
    assert mjcf.returncode == 1 and "mjcf_compile" in mjcf.stdout and "more than the 64 MB" in mjcf.stdout, mjcf.stdout
    fails_cleanly(
        meshes, "init", str(meshes / "sparse.urdf"), "--out", str(meshes / "sparse.yaml"), match="more than the 64 MB"
    )


def test_a_million_triangles_are_read_within_the_bounds(meshes: Path) -> None:
    done = _validate(str(meshes / "million.urdf"), "--tier", "full")
    assert done.returncode == 1, done.stdout + done.stderr
    assert ": meshes:" not in done.stdout, done.stdout  # read, and its size judged: no finding
    assert "mujoco_compile" in done.stdout and "200000" in done.stdout, done.stdout  # MuJoCo's own STL limit
    fails_cleanly(
        meshes, "init", str(meshes / "million.urdf"), "--out", str(meshes / "m.yaml"), match="more than the 200,000"
    )
