"""benchmarks/learn_deploy.py's bad input: one ``error:`` line, exit 2, no page written (the runs themselves need the
ROS 2 venv and a trained actor: tests/learn/test_deploy.py covers ``svhdesc deploy``). Seeded fault: the unknown
task's SvhdescError left uncaught -> a traceback, exit 1."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from tests.support import REPO

SCRIPT = REPO / "benchmarks" / "learn_deploy.py"


@pytest.mark.parametrize(
    ("args", "match"),
    [
        (["no_such_task"], "unknown task 'no_such_task'"),
        (["svh_rotate", "--policy", "/nonexistent/policy.onnx"], "/nonexistent/policy.onnx: no such policy"),
        (["svh_rotate", "--episodes", "0"], "--episodes must be at least 1"),
    ],
)
def test_bad_input_is_one_error_line(args: list[str], match: str, tmp_path: Path) -> None:
    result = subprocess.run([sys.executable, str(SCRIPT), *args], capture_output=True, text=True, cwd=tmp_path)
    errors = [line for line in result.stderr.splitlines() if line.startswith("error:")]
    assert result.returncode == 2 and len(errors) == 1 and "Traceback" not in result.stderr, result.stderr
    assert match in errors[0]
