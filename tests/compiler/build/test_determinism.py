"""Outputs do not depend on the CPU: CPU-independent arithmetic, and --check's numeric tolerance
(svhdesc.compiler.build.agreement).

No second machine here, so the tests perturb the computation by a few ulps (SVHDESC_PERTURB_ULPS), which is what
another CPU's kernels would do, and show --check still passes; and they move one written number by 1e-9 of itself,
which --check must catch.
"""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import trimesh

from svhdesc.compiler import exact
from svhdesc.compiler.build.agreement import RTOL, file_difference, text_difference
from tests.support import REPO, run_cli

PERTURB = {exact.PERTURB_ENV: "4"}


@pytest.mark.slow
def test_perturbed_build_differs_in_bytes_but_passes_check(tmp_path: Path) -> None:
    out = tmp_path / "gen"
    result = run_cli("build", "svh_right", "--force", "--out", str(out), env=PERTURB)
    assert result.returncode == 0, result.stderr
    fresh, committed = out / "svh_right" / "svh_right.xml", REPO / "generated" / "svh_right" / "svh_right.xml"
    assert fresh.read_bytes() != committed.read_bytes()  # the perturbation reached the written numbers
    assert file_difference(fresh, committed) is None
    check = run_cli("build", "--check", "--force", "svh_right", env=PERTURB)
    assert check.returncode == 0, check.stderr


def _bump_number(text: str, attribute: str, index: int, factor: float) -> str:
    match = re.search(rf'{attribute}="([^"]*)"', text)
    assert match is not None
    values = match.group(1).split()
    values[index] = repr(float(values[index]) * factor)
    return text[: match.start(1)] + " ".join(values) + text[match.end(1) :]


@pytest.mark.slow
@pytest.mark.parametrize("index", [0, 5])  # a diagonal moment and the smallest off-diagonal product
def test_check_fails_on_a_change_of_1e9_relative(tmp_path: Path, index: int) -> None:
    out = tmp_path / "gen"
    shutil.copytree(REPO / "generated" / "svh_right", out / "svh_right")
    mjcf = out / "svh_right" / "svh_right.xml"
    mjcf.write_text(_bump_number(mjcf.read_text(), "fullinertia", index, 1.0 + 1e-9))
    result = run_cli("build", "--check", "--out", str(out), "svh_right")
    assert result.returncode == 1
    assert "svh_right/svh_right.xml (differs: line" in result.stderr, result.stderr


def test_text_agreement_rule() -> None:
    old = b'<inertial mass="0.26953066074380394" diag="1e-20 0"/>'
    assert text_difference(old.replace(b"0.26953066074380394", b"0.269530660743804"), old) is None
    moved = repr(0.26953066074380394 * (1 + 1e-9)).encode()
    assert "line 1" in (text_difference(old.replace(b"0.26953066074380394", moved), old) or "")
    assert text_difference(old.replace(b"mass", b"mast"), old) is not None
    assert text_difference(old + b" ", old) is not None
    assert RTOL < 1e-9


def _box_with_a_notch() -> trimesh.Trimesh:
    return trimesh.creation.box(extents=(0.03, 0.01, 0.02)).difference(
        trimesh.creation.box(
            extents=(0.01, 0.02, 0.01), transform=trimesh.transformations.translation_matrix((0.01, 0, 0.01))
        )
    )


def test_mass_properties_independent_of_face_order_and_equal_to_trimesh() -> None:
    mesh = _box_with_a_notch()
    mesh.apply_transform(trimesh.transformations.random_rotation_matrix(np.random.default_rng(3).random(3)))
    volume, centre, inertia = exact.mass_properties(mesh.vertices, mesh.faces)
    order = np.random.default_rng(7).permutation(len(mesh.faces))
    again = exact.mass_properties(mesh.vertices, mesh.faces[order])
    assert again[0] == volume and np.array_equal(again[1], centre) and np.array_equal(again[2], inertia)
    assert volume == pytest.approx(mesh.volume, rel=1e-12)
    assert np.allclose(centre, mesh.center_mass, rtol=0, atol=1e-15)
    assert np.allclose(inertia, mesh.moment_inertia / mesh.density, rtol=1e-10, atol=1e-20)


def test_jacobi_eigensolver_matches_lapack() -> None:
    rng = np.random.default_rng(11)
    for _ in range(20):
        a = rng.normal(size=(3, 3))
        matrix = a @ a.T
        values, vectors = exact.eigh3(matrix)
        assert np.allclose(values, np.linalg.eigvalsh(matrix), rtol=1e-12, atol=1e-14)
        assert np.allclose(exact.matmul(matrix, vectors), vectors * values, atol=1e-12)
        assert np.allclose(vectors.T @ vectors, np.eye(3), atol=1e-14)


def test_matmul_without_blas_matches() -> None:
    rng = np.random.default_rng(5)
    a, b = rng.normal(size=(7, 4)), rng.normal(size=(4, 3))
    assert np.allclose(exact.matmul(a, b), a @ b, rtol=1e-14, atol=1e-15)


def _author(out: Path, env: dict[str, str]) -> None:
    result = subprocess.run(
        [sys.executable, str(REPO / "tools" / "author_meshes.py"), "--out", str(out)],
        capture_output=True,
        text=True,
        timeout=300,
        env={**os.environ, **env},
    )
    assert result.returncode == 0, result.stderr


def test_mesh_authoring_agrees_with_the_committed_meshes_when_perturbed(tmp_path: Path) -> None:
    _author(tmp_path, PERTURB)
    committed = sorted((REPO / "meshes").rglob("*.dae"))
    assert len(committed) == 30
    for path in committed:
        fresh = tmp_path / path.parent.name / path.name
        assert file_difference(fresh, path) is None, f"{path.relative_to(REPO)} differs from the script's output"
