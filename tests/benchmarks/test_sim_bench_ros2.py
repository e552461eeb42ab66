"""benchmarks/sim_bench_ros2.py on bad input: one ``error:`` line, exit 2, nothing written, before anything starts.

Seeded fault: main's BenchError handler removed (the exception let through) -> each case fails with a traceback.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]
SCRIPT = REPO / "benchmarks" / "sim_bench_ros2.py"
PAGE = REPO / "docs" / "results" / "node_speed_ros2.md"


@pytest.mark.parametrize(
    ("args", "env", "words"),
    [
        (["soon"], {}, "WINDOW must be a number"),
        (["0"], {}, "WINDOW must be positive"),
        (["1", "no_such_variant"], {}, "unknown variant(s) no_such_variant"),
        (["1", "svh_right"], {"SVHDESC_ROS2_PYTHON": "/nonexistent/python"}, "no ROS 2 Python at /nonexistent/python"),
    ],
)
def test_bad_input_one_error_line(args: list[str], env: dict[str, str], words: str) -> None:
    before = PAGE.stat().st_mtime_ns if PAGE.exists() else None
    result = subprocess.run(
        [sys.executable, str(SCRIPT), *args],
        capture_output=True,
        text=True,
        env={**os.environ, "PYTHONPATH": str(REPO), **env},
        timeout=120,
        check=False,
    )
    lines = result.stderr.strip().splitlines()
    assert result.returncode == 2, result.stderr
    assert len(lines) == 1 and lines[0].startswith("error:") and words in lines[0], result.stderr
    assert (PAGE.stat().st_mtime_ns if PAGE.exists() else None) == before
