"""Session-wide test settings and shared fixtures.

- The Warp kernel cache; the run's folder with its hull cache (never the user's) and its one session build, shared
  by pytest-xdist's workers.
- The `ros` and `slow` markers: `pytest -m "not slow"` is the quick set for development; the README's command and
  CI run everything in one process (`-n auto --dist loadgroup` spreads a run over pytest-xdist workers).
- `vendor_build`: the upstream descriptions (config/vendor.yaml) built once per worker; its users share an xdist
  group so that one worker builds it.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import tempfile
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
# MuJoCo Warp compiles its kernels once into the repo's ignored .cache/ (inherited by CLI subprocesses too).
os.environ.setdefault("WARP_CACHE_PATH", str(REPO / ".cache" / "warp"))
# One folder for the whole run, made by the controller (or the only process) and inherited by xdist's workers: the
# decomposition cache (never the user's) and the session build (tests/support.py built()).
OWN_RUN = "SVHDESC_TEST_RUN" not in os.environ
if OWN_RUN:
    os.environ["SVHDESC_TEST_RUN"] = tempfile.mkdtemp(prefix="svhdesc-test-run-")
    os.environ.setdefault("SVHDESC_CACHE", str(Path(os.environ["SVHDESC_TEST_RUN"]) / "hulls"))


def pytest_unconfigure(config: pytest.Config) -> None:
    if OWN_RUN and not hasattr(config, "workerinput"):  # the controller (or a run without xdist) made it
        shutil.rmtree(os.environ["SVHDESC_TEST_RUN"], ignore_errors=True)


# Modules that start a ROS master (in a private network namespace, on 127.0.0.1).
ROS_MODULES = {"test_consumers", "test_pick_and_place", "test_plan_ros", "test_node", "test_robustness"}
# Modules whose tests take tens of seconds each (engines, grasps held for seconds, Warp, vendor decompositions).
SLOW_MODULES = {"test_env", "test_grasps", "test_fidelity", "test_compare", "test_plan", "test_wireloop"}


def pytest_collection_modifyitems(items: list[pytest.Item]) -> None:
    for item in items:
        module = item.module.__name__.rsplit(".", 1)[-1] if item.module else ""
        if module in ROS_MODULES:
            item.add_marker(pytest.mark.ros)
        if module in SLOW_MODULES or module in ROS_MODULES:
            item.add_marker(pytest.mark.slow)


@pytest.fixture(scope="session")
def vendor_build(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, subprocess.CompletedProcess[str]]:
    """config/vendor.yaml's three variants built from ../shared/vendor: (out, the build's result)."""
    from .support import VENDOR_SVH, VENDOR_UR, run_cli

    if not VENDOR_SVH.is_dir():
        pytest.skip("../shared/vendor is not beside this checkout")
    out = tmp_path_factory.mktemp("vendor")
    packages = ("--package", f"schunk_svh_driver={VENDOR_SVH}", "--package", f"ur_description={VENDOR_UR}")
    result = run_cli("build", "--config", str(REPO / "config" / "vendor.yaml"), "--out", str(out), *packages)
    assert result.returncode == 0, result.stderr
    return out, result
