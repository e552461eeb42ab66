"""Shared helpers for the tests: one build of every variant per session, and a CLI runner."""

from __future__ import annotations

import fcntl
import functools
import os
import subprocess
import sys
import tempfile
from pathlib import Path

from svhdesc.compiler.settings.config import load_config

TESTS = Path(__file__).resolve().parent
REPO = TESTS.parent
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
    """A fresh build of every variant (not the committed one), shared by the whole run: the first xdist worker to
    ask builds it under the run's folder (tests/conftest.py), the others wait for it and read it."""
    run = Path(os.environ.get("SVHDESC_TEST_RUN") or tempfile.mkdtemp(prefix="svhdesc-test-run-"))
    out, done = run / "build", run / "build.done"
    with open(run / "build.lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        if not done.exists():
            result = run_cli("build", "--out", str(out))
            assert result.returncode == 0, result.stderr
            done.touch()
    return out


def model_files(variant: str) -> tuple[Path, Path]:
    directory = built() / variant
    return directory / f"{variant}.urdf", directory / f"{variant}.xml"
