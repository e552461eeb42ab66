"""``svhdesc sim --ros2`` and ``--record`` on the command line, without ROS 2: bad combinations and a Python without
rclpy give one ``error:`` line and exit 2 (no traceback). Fast: nothing starts.

Seeded fault: svhdesc/ros2/system.py's import_rclpy letting ImportError through (a bare ``import rclpy``) ->
test_without_rclpy_one_error_line fails (a traceback, not one line naming .venv-ros2)."""

from __future__ import annotations

import importlib.util
import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]


def _sim(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "svhdesc.cli", "sim", "svh_right", *args],
        capture_output=True,
        text=True,
        env={**os.environ, "PYTHONPATH": str(ROOT)},
        timeout=120,
        check=False,
    )


def _one_error(result: subprocess.CompletedProcess[str], *words: str) -> None:
    lines = result.stderr.strip().splitlines()
    assert result.returncode == 2, result.stderr
    assert len(lines) == 1 and lines[0].startswith("error:"), result.stderr
    assert all(word in lines[0] for word in words), lines[0]


def test_without_rclpy_one_error_line() -> None:
    """Run from .venv (no rclpy): one line naming .venv-ros2 and `tools/install.sh ros2`, exit 2."""
    if importlib.util.find_spec("rclpy") is not None:
        pytest.skip("this Python has rclpy")
    _one_error(_sim("--ros2", "--duration", "0.1"), ".venv-ros2", "tools/install.sh ros2")


def test_ros_and_ros2_exclude_each_other() -> None:
    _one_error(_sim("--ros", "--ros2"), "--ros and --ros2")


def test_record_needs_ros2(tmp_path: Path) -> None:
    _one_error(_sim("--record", str(tmp_path / "x.mcap"), "--duration", "0.1"), "--record needs --ros2")
    assert not list(tmp_path.iterdir())
