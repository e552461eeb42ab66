"""The pytest plugin, run for real: plain `pytest` in a repository with a [tool.svhdesc] table collects one item per
model x check, fails a check with its findings at file:line, and works with -k, JUnit XML and xdist."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest
from lxml import etree

from tests.validate.test_repo_settings import PYPROJECT
from tests.validate.test_static_files import MACROS, XACRO


@pytest.fixture(scope="module")
def repo(tmp_path_factory: pytest.TempPathFactory) -> Path:
    root = tmp_path_factory.mktemp("robot_repo")
    (root / "urdf").mkdir()
    # The right side's shoulder has its limits inverted; the left one's are clean.
    (root / "urdf" / "arm.urdf.xacro").write_text(XACRO.replace("${LOWER}", "${-1.0 if side == 'left' else 2.0}"))
    (root / "urdf" / "macros.xacro").write_text(MACROS)
    (root / "pyproject.toml").write_text(PYPROJECT.format(extra=""))
    (root / "tests").mkdir()
    (root / "tests" / "test_own.py").write_text("def test_own():\n    pass\n")
    return root


def _pytest(repo: Path, *args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "pytest", "-p", "no:cacheprovider", "-rfs", *args],
        cwd=repo,
        capture_output=True,
        text=True,
        timeout=300,
    )


def test_plain_pytest_collects_model_by_check(repo: Path) -> None:
    result = _pytest(repo, "--collect-only", "-q")
    ids = [line for line in result.stdout.splitlines() if "::" in line]
    model = "urdf/arm.urdf.xacro::"
    assert f"{model}joint_limits[side=left]" in ids and f"{model}mimic[side=right]" in ids
    assert "tests/test_own.py::test_own" in ids
    # xml, the six URDF rules (meshes: skipped), the three parsers, then the full tier's MuJoCo compile and seven
    # simulated checks
    assert len([i for i in ids if i.endswith("[side=left]")]) == 18
    assert f"{model}gravity_hold[side=right]" in ids
    # Given paths, pytest runs those only; --svhdesc adds the models.
    narrowed = _pytest(repo, "--collect-only", "-q", "tests")
    assert "arm.urdf.xacro" not in narrowed.stdout
    assert "arm.urdf.xacro" in _pytest(repo, "--collect-only", "-q", "tests", "--svhdesc").stdout


def test_a_failing_check_names_its_file_line_and_junit_records_it(repo: Path) -> None:
    junit = repo / "report.xml"
    result = _pytest(repo, f"--junitxml={junit}")
    assert result.returncode == 1, result.stdout + result.stderr
    line = MACROS.splitlines().index('    <joint name="${prefix}_shoulder" type="revolute">') + 1
    assert f"macros.xacro:{line}: joint 'right_shoulder': lower 2 > upper 1" in result.stdout, result.stdout
    assert "FAILED urdf/arm.urdf.xacro::joint_limits[side=right]" in result.stdout
    assert "the meshes live in a submodule" in result.stdout  # the ignore's reason, as the skip's
    cases = {f"{c.get('classname')}::{c.get('name')}": c for c in etree.parse(str(junit)).iter("testcase")}
    failed = [name for name, case in cases.items() if case.find("failure") is not None]
    assert failed == ["urdf.arm.urdf.xacro::joint_limits[side=right]"], failed


def test_k_selects_and_xdist_shares_the_work(repo: Path) -> None:
    only_left = _pytest(repo, "-k", "left and joint_limits", "-q")
    assert only_left.returncode == 0 and "1 passed" in only_left.stdout, only_left.stdout
    spread = _pytest(repo, "-n", "2", "--dist", "loadgroup", "-q")
    assert spread.returncode == 1 and "1 failed" in spread.stdout, spread.stdout + spread.stderr
