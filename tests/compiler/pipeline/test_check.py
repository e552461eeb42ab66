"""``build --check`` trusts nothing in the folder it checks: it rebuilds from the sources and compares every file,
so a hand-edited output shows whatever its manifest says (issue 28)."""

from __future__ import annotations

import hashlib
import json
import shutil
from pathlib import Path

import pytest

from svhdesc.compiler.pipeline.builder import differences as differences_of
from tests.support import HULL_CHECK, REPO, VARIANTS, build_counts, run_cli

# The session build (tests/support.py built()) is the run's build from the sources alone: every collision mesh
# decomposed, every sampled result sampled again. The guard below compares it with generated/ as `build --check`
# compares (builder.differences); the CLI's --check itself, which trusts no cache either, is tested on the mini
# robot (test_hull_trust.py) and, with --trust-cache, below and in test_determinism.py.
pytestmark = HULL_CHECK


@pytest.mark.slow
def test_committed_generated_models_are_current(session_build: Path) -> None:
    """The CI guard: generated/ is what the sources give, file for file (bytes, or numbers within 1e-10), the
    hulls decomposed afresh (seeded fault: the session build seeding its hulls from generated/: "24 from committed
    outputs"; a hull of generated/ edited: "assets/... (differs")."""
    counts = build_counts()
    assert counts.get("decomposed", 0) > 0 and counts.get("cached", 0) == counts.get("committed", 0) == 0, counts
    differences = [line for v in VARIANTS for line in differences_of(session_build / v, REPO / "generated" / v, v)]
    assert differences == []


def _edit_with_manifest(variant: Path, relative: str, old: str, new: str) -> None:
    """Change one output and write its new hash into the manifest, as a careful hand edit would."""
    path = variant / relative
    text = path.read_text()
    assert old in text
    path.write_text(text.replace(old, new, 1))
    manifest = json.loads((variant / "manifest.json").read_text())
    manifest["outputs"][relative] = hashlib.sha256(path.read_bytes()).hexdigest()
    (variant / "manifest.json").write_text(json.dumps(manifest, indent=1, sort_keys=True) + "\n")


@pytest.mark.slow
def test_a_hand_edited_output_and_manifest_are_reported(tmp_path: Path) -> None:
    """A hull and the URDF edited together with their manifest hashes, which then agree with the files: --check
    names both (seeded fault: _write_all seeding hulls from the checked folder, and the edited hull passes)."""
    out = tmp_path / "gen"
    shutil.copytree(REPO / "generated" / "svh_right", out / "svh_right")
    variant = out / "svh_right"
    hull = sorted((variant / "assets").glob("t_hull_*.obj"))[0]
    first_vertex = next(line for line in hull.read_text().splitlines() if line.startswith("v "))
    x = first_vertex.split()[1]
    _edit_with_manifest(variant, f"assets/{hull.name}", first_vertex, first_vertex.replace(x, repr(float(x) + 1e-4)))
    _edit_with_manifest(variant, "svh_right.urdf", 'effort="', 'effort="1')
    before = {p: p.read_bytes() for p in variant.rglob("*") if p.is_file()}
    result = run_cli("build", "--check", "--trust-cache", "--out", str(out), "svh_right")
    assert result.returncode == 1, result.stderr
    assert f"svh_right/assets/{hull.name} (differs" in result.stderr, result.stderr
    assert "svh_right/svh_right.urdf (differs" in result.stderr
    assert "svh_right/manifest.json (differs" in result.stderr
    assert {p: p.read_bytes() for p in variant.rglob("*") if p.is_file()} == before  # --check changes nothing
