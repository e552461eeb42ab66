"""Session-wide test settings: the Warp kernel cache, and the `ros` and `slow` markers.

`pytest -m "not slow and not ros"` is the quick set for development; the README's command and CI run everything.
"""

import os
from pathlib import Path

import pytest

# MuJoCo Warp compiles its kernels once into the repo's ignored .cache/ (inherited by CLI subprocesses too).
os.environ.setdefault("WARP_CACHE_PATH", str(Path(__file__).resolve().parents[1] / ".cache" / "warp"))

# Modules that start a ROS master (in a private network namespace, on 127.0.0.1).
ROS_MODULES = {"test_consumers", "test_pick_and_place", "test_plan_ros", "test_ros", "test_ros_robustness"}
# Modules whose tests take tens of seconds each (engines, grasps held for seconds, Warp, vendor decompositions).
SLOW_MODULES = {"test_batch", "test_grasps", "test_fidelity", "test_compare", "test_plan", "test_wireloop"}


def pytest_collection_modifyitems(items: list[pytest.Item]) -> None:
    for item in items:
        module = item.module.__name__.rsplit(".", 1)[-1] if item.module else ""
        if module in ROS_MODULES:
            item.add_marker(pytest.mark.ros)
        if module in SLOW_MODULES or module in ROS_MODULES:
            item.add_marker(pytest.mark.slow)
