"""benchmarks/sim_bench_ros2.py and ros2_goal_burst.py on bad input: one ``error:`` line, exit 2, nothing written,
before anything starts.

Seeded fault: main's BenchError handler removed (the exception let through) -> each case fails with a traceback.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]
SPEED = (REPO / "benchmarks" / "sim_bench_ros2.py", REPO / "docs" / "results" / "node_speed_ros2.md")
BURST = (REPO / "benchmarks" / "ros2_goal_burst.py", REPO / "docs" / "results" / "ros2_goal_burst.md")
NO_PYTHON = {"SVHDESC_ROS2_PYTHON": "/nonexistent/python"}


@pytest.mark.parametrize(
    ("script", "args", "env", "words"),
    [
        (SPEED, ["soon"], {}, "WINDOW must be a number"),
        (SPEED, ["0"], {}, "WINDOW must be positive"),
        (SPEED, ["1", "no_such_variant"], {}, "unknown variant(s) no_such_variant"),
        (SPEED, ["1", "svh_right"], NO_PYTHON, "no ROS 2 Python at /nonexistent/python"),
        (BURST, ["many"], {}, "COUNT must be a whole number"),
        (BURST, ["2"], {}, "COUNT must be between 3 and 5000"),
        (BURST, ["30"], NO_PYTHON, "no ROS 2 Python at /nonexistent/python"),
    ],
)
def test_bad_input_one_error_line(script: tuple[Path, Path], args: list[str], env: dict[str, str], words: str) -> None:
    path, page = script
    before = page.stat().st_mtime_ns if page.exists() else None
    result = subprocess.run(
        [sys.executable, str(path), *args],
        capture_output=True,
        text=True,
        env={**os.environ, "PYTHONPATH": str(REPO), **env},
        timeout=120,
        check=False,
    )
    lines = result.stderr.strip().splitlines()
    assert result.returncode == 2, result.stderr
    assert len(lines) == 1 and lines[0].startswith("error:") and words in lines[0], result.stderr
    assert (page.stat().st_mtime_ns if page.exists() else None) == before
