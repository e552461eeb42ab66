"""The code fingerprint in every manifest: a change to code that makes models rebuilds them; a change to code that
only reads them (validate, the runtime wing, the CLI) does not."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest

import svhdesc
from svhdesc.compiler.pipeline import freshness

PACKAGE = Path(svhdesc.__file__).resolve().parent


def test_fingerprint_covers_the_whole_package() -> None:
    assert freshness.PACKAGE_DIR == PACKAGE
    assert freshness.code_fingerprint() == freshness.fingerprint_of(PACKAGE)


@pytest.mark.parametrize(
    ("module", "makes_models"),
    [
        ("compiler/stages/inertials.py", True),
        ("compiler/export/mjcf.py", True),
        ("core/source/urdf.py", True),
        ("ir.py", True),
        ("model.py", True),  # the exporters read the driver's names and the batch model's constants from it
        ("validate/runner.py", False),
        ("sim/runtime.py", False),
        ("batch/env.py", False),
        ("cli.py", False),
    ],
)
def test_a_change_rebuilds_only_where_it_makes_models(tmp_path: Path, module: str, makes_models: bool) -> None:
    copy = tmp_path / "svhdesc"
    shutil.copytree(PACKAGE, copy, ignore=shutil.ignore_patterns("__pycache__"))
    before = freshness.fingerprint_of(copy)
    with (copy / module).open("a") as handle:
        handle.write("\n# changed\n")
    assert (freshness.fingerprint_of(copy) != before) is makes_models


def test_the_models_a_wheel_ships_in_the_package_are_not_code(tmp_path: Path) -> None:
    """An installed wheel holds generated/ (with the ROS 2 launch files) inside svhdesc/: they are outputs.
    Seeded fault: without SHIPPED in makes_models the fingerprint changes."""
    copy = tmp_path / "svhdesc"
    shutil.copytree(PACKAGE, copy, ignore=shutil.ignore_patterns("__pycache__"))
    before = freshness.fingerprint_of(copy)
    launch = copy / "generated" / "ur5_svh_right" / "ros2" / "launch" / "sim.launch.py"
    launch.parent.mkdir(parents=True)
    launch.write_text("PACKAGE = 'ur5_svh_right'\n")
    assert freshness.fingerprint_of(copy) == before
