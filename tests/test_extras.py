"""Optional dependencies: every command names the extra it needs, in one line, exit 2."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from tests.support import REPO

# Run the CLI with one optional module made unimportable, as on a machine without that extra.
BLOCKED_CLI = "import sys; sys.modules[{module!r}] = None; from svhdesc.cli import main; main()"


def run_without(module: str, *args: str, cwd: Path = REPO) -> subprocess.CompletedProcess[str]:
    code = BLOCKED_CLI.format(module=module)
    return subprocess.run([sys.executable, "-c", code, *args], capture_output=True, text=True, cwd=cwd, timeout=300)


@pytest.mark.parametrize(
    ("module", "args", "extra"),
    [
        ("mujoco", ("build", "svh_right", "--force", "--out", "{tmp}/out"), "build"),
        ("trimesh", ("build", "svh_right", "--force", "--out", "{tmp}/out"), "build"),
        ("xacro", ("info", "svh_right"), "build"),
        ("mujoco", ("render", "svh_right", "--out", "{tmp}/x.png"), "sim"),
        ("mujoco", ("validate", "svh_right", "--checks", "simulate"), "validate"),
        ("matplotlib", ("validate", "svh_right", "--checks", "contact_stability", "--plots", "{tmp}/p"), "validate"),
        ("yourdfpy", ("validate", "svh_right", "--checks", "kinematics"), "validate"),
        ("ompl", ("plan", "ur5_svh_right", "--group", "manipulator", "--from", "home", "--to", "test"), "plan"),
        ("ruckig", ("plan", "ur5_svh_right", "--group", "manipulator", "--from", "home", "--to", "test"), "plan"),
    ],
)
def test_missing_extra_is_one_line_naming_it(tmp_path: Path, module: str, args: tuple[str, ...], extra: str) -> None:
    result = run_without(module, *(a.format(tmp=tmp_path) for a in args))
    assert result.returncode == 2, result.stderr[-2000:]
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1, result.stderr
    assert lines[0].startswith(f"error: 'svhdesc {args[0]}' needs the Python package")
    assert lines[0].endswith(f"pip install 'svhdesc[{extra}]'")
    assert not (tmp_path / "out").exists() and not (tmp_path / "x.png").exists()


def test_require_names_the_extra() -> None:
    from svhdesc.extras import MissingExtra, require

    assert require("json").dumps([]) == "[]"
    with pytest.raises(
        MissingExtra, match=r"'svhdesc_no_such_module', which is not installed: pip install 'svhdesc\[x\]'"
    ):
        require("svhdesc_no_such_module", extra="x")
