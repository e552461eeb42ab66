"""The ROS 2 tests that import the Jazzy wheels themselves (interfaces, the package install, the parameter files)
skip in `.venv`, which has no rclpy. From the README's test command they run here, in the ROS 2 venv's Python
(``.venv-ros2/bin/python`` of this checkout, or $SVHDESC_ROS2_PYTHON), and must pass there without a skip
(seeded: a field deleted from the committed FollowJointTrajectory.action fails test_interfaces, and so this)."""

from __future__ import annotations

import importlib.util
import os
from pathlib import Path

import pytest

from tests.support import pytest_in_venv

ROOT = Path(__file__).resolve().parents[2]
PYTHON = Path(os.environ.get("SVHDESC_ROS2_PYTHON", ROOT / ".venv-ros2" / "bin" / "python"))
IN_ROS2_VENV = ("test_interfaces.py", "test_package_install.py", "test_parameter_files.py")

pytestmark = pytest.mark.slow  # a pytest of its own in the other venv: a few seconds, more on a busy machine


@pytest.mark.skipif(importlib.util.find_spec("rclpy") is not None, reason="rclpy is here: those tests run directly")
@pytest.mark.skipif(not PYTHON.is_file(), reason=f"no ROS 2 Python at {PYTHON} (bash tools/install.sh ros2)")
def test_the_ros2_venv_tests_pass_there(tmp_path: Path) -> None:
    files = [str(Path(__file__).with_name(name)) for name in IN_ROS2_VENV]
    pytest_in_venv(PYTHON, files, tmp_path)
