"""Shared helpers for the tests: one build of every variant per session, and a CLI runner."""

from __future__ import annotations

import functools
import os
import subprocess
import sys
import tempfile
from pathlib import Path

from svhdesc.config import load_config

REPO = Path(__file__).resolve().parents[1]
SHARED = REPO.parent / "shared"
VENDOR_SVH = SHARED / "vendor" / "schunk_svh_driver"
VENDOR_UR = SHARED / "vendor" / "ur_description"
# From the config, not a copy of it: a variant added there is tested everywhere.
VARIANTS = tuple(load_config(REPO / "config" / "svhdesc.yaml").variants)


def run_cli(*args: str, cwd: Path = REPO, env: dict[str, str] | None = None) -> subprocess.CompletedProcess[str]:
    """``svhdesc ARGS`` in a subprocess; ``env`` adds to the inherited environment."""
    return subprocess.run(
        [sys.executable, "-m", "svhdesc.cli", *args],
        cwd=cwd,
        capture_output=True,
        text=True,
        timeout=600,
        env={**os.environ, **(env or {})},
    )


@functools.cache
def built() -> Path:
    """A fresh build of every variant (not the committed one), shared by the whole session."""
    out = Path(tempfile.mkdtemp(prefix="svhdesc-test-build-"))
    result = run_cli("build", "--out", str(out))
    assert result.returncode == 0, result.stderr
    return out


def model_files(variant: str) -> tuple[Path, Path]:
    directory = built() / variant
    return directory / f"{variant}.urdf", directory / f"{variant}.xml"
