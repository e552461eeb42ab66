"""Which hulls a build reuses, and what ``build --check`` trusts (docs/build.md): the mini robot with its
finger's collision mesh decomposed, so that every decomposition takes a fraction of a second.

- A cache entry forged within the fit check's tolerance (the same hull shrunk by 2 %, digests rewritten) is served
  to a build, as documented; ``build --check`` decomposes afresh and reports the hull it wrote; ``--check
  --trust-cache`` does not.
- Hulls in ``--out`` edited with their manifest entries seed ``build --force`` only if they pass the same check.
"""

from __future__ import annotations

import hashlib
import json
from collections.abc import Callable
from pathlib import Path

import pytest
import trimesh

from svhdesc.compiler.decompose.cache import HullCache
from svhdesc.core.source.meshes import mesh_from_stl, obj_bytes, stl_bytes
from tests.support import run_cli


@pytest.fixture
def decomposed(project: Callable[..., Path]) -> Path:
    """The mini robot, its finger's collision cube decomposed and unscaled (a scaled mesh's hulls seed nothing)."""
    root = project("mini")
    text = (root / "mini.yaml").read_text()
    (root / "mini.yaml").write_text(text.replace("collision: {mode: hull}", "collision: {mode: decompose}"))
    finger = (root / "finger.xacro").read_text()
    (root / "finger.xacro").write_text(finger.replace('filename="cube.stl" scale="1 1 2"', 'filename="cube.stl"'))
    return root


def build(root: Path, out: Path, cache: Path, *args: str) -> tuple[int, str]:
    result = run_cli(
        "build", "--config", str(root / "mini.yaml"), "--out", str(out), *args, env={"SVHDESC_CACHE": str(cache)}
    )
    return result.returncode, result.stderr


def entries(cache: Path) -> list[Path]:
    """The hull entries (named by their 64-digit key; the sampled results live in folders of their own)."""
    return [p for p in cache.iterdir() if p.is_dir() and len(p.name) == 64]


def hull_files(variant: Path) -> dict[str, bytes]:
    return {p.name: p.read_bytes() for p in sorted((variant / "assets").glob("*_hull_*.obj"))}


def shrunk(mesh: trimesh.Trimesh, factor: float) -> trimesh.Trimesh:
    moved = mesh.copy()
    centre = moved.bounds.mean(axis=0)
    moved.vertices = centre + (moved.vertices - centre) * factor
    return moved


@pytest.mark.slow
def test_check_decomposes_afresh_unless_it_trusts_the_cache(tmp_path: Path, decomposed: Path) -> None:
    """Seeded fault: --check without --trust-cache reading the cache (HullSource force off) passes the forgery."""
    cache, clean, out = tmp_path / "cache", tmp_path / "clean", tmp_path / "out"
    assert build(decomposed, clean, cache)[0] == 0
    (entry,) = entries(cache)
    blobs = sorted(entry.glob("hull_*.stl"))
    forged = [stl_bytes(shrunk(mesh_from_stl(p.read_bytes()), 0.98)) for p in blobs]
    HullCache(cache).put(entry.name, forged)  # what rewriting the entry's digests gives
    code, stderr = build(decomposed, out, cache)
    assert code == 0 and "warning" not in stderr, stderr  # within the fit check's tolerance: served
    assert hull_files(out / "mini") != hull_files(clean / "mini")
    code, stderr = build(decomposed, out, cache, "--check", "--trust-cache")
    assert code == 0, stderr  # the documented trust: the forged entry agrees with what it wrote
    code, stderr = build(decomposed, out, cache, "--check")
    assert code == 1 and "mini/assets/cube_hull_00.obj (differs" in stderr, stderr
    after = tmp_path / "after"
    assert build(decomposed, after, cache)[0] == 0  # --check healed the entry: a new build has the clean hulls
    assert hull_files(after / "mini") == hull_files(clean / "mini")


def test_trust_cache_goes_with_check_only(tmp_path: Path, decomposed: Path) -> None:
    code, stderr = build(decomposed, tmp_path / "out", tmp_path / "cache", "--trust-cache")
    assert code == 2 and stderr.startswith("error: --trust-cache goes with --check"), stderr


@pytest.mark.slow
def test_force_takes_hulls_from_out_only_if_they_fit(tmp_path: Path, decomposed: Path) -> None:
    """A hull of --out replaced by one twice its size, its manifest hash rewritten, and the cache emptied so that
    the out's hulls are the only seed: --force warns once and decomposes again (seeded fault: HullSource._seeded
    without misfit_hulls writes the edited hull out again)."""
    cache, out = tmp_path / "cache", tmp_path / "out"
    assert build(decomposed, out, cache)[0] == 0
    clean = hull_files(out / "mini")
    variant = out / "mini"
    name = next(iter(clean))
    grown = shrunk(trimesh.load(variant / "assets" / name, process=False), 2.0)
    (variant / "assets" / name).write_bytes(obj_bytes(grown))
    manifest = json.loads((variant / "manifest.json").read_text())
    manifest["outputs"][f"assets/{name}"] = hashlib.sha256((variant / "assets" / name).read_bytes()).hexdigest()
    (variant / "manifest.json").write_text(json.dumps(manifest, indent=1, sort_keys=True) + "\n")
    for entry in entries(cache):
        for file in entry.iterdir():
            file.unlink()
        entry.rmdir()
    code, stderr = build(decomposed, out, cache, "--force")
    assert code == 0, stderr
    warnings = [line for line in stderr.splitlines() if line.startswith("warning:")]
    assert len(warnings) == 1 and name in warnings[0] and "beyond the mesh's convex hull" in warnings[0], stderr
    assert hull_files(variant) == clean
