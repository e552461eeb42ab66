"""Issue 26, B and C: ``python:`` paths reach data folders in site-packages (example-robot-data's
``cmeel.prefix/share``) without importing anything; ``package:///NAME/...`` reads as ``package://NAME/...``;
``arm.joints`` alone turns the arm on; an undriven joint's error names the key that would drive it."""

from __future__ import annotations

import subprocess
import sys
import sysconfig
from pathlib import Path

import pytest
from lxml import etree

from svhdesc.core.settings.config import load_config, resolve_path
from svhdesc.core.source.packages import resolve_uri
from svhdesc.core.source.urdf import read_urdf
from svhdesc.errors import SvhdescError
from tests.core.settings.test_any_robot import NO_HAND, build, project, urdf
from tests.support import REPO, fails_cleanly

ROBOTS = "python:cmeel.prefix/share/example-robot-data/robots"


# --- python: ------------------------------------------------------------------------------------------------


def test_python_paths_reach_a_data_folder_in_site_packages(tmp_path: Path) -> None:
    """example-robot-data installs data, not a package: found where pip put it. Seeded fault: looking NAME up as a
    package only (the old find_spec) refuses it with "no installed Python package 'cmeel.prefix'"."""
    found = resolve_path(f"{ROBOTS}/panda_description", tmp_path, "here")
    site = Path(sysconfig.get_paths()["purelib"]).resolve()
    assert found == site / "cmeel.prefix" / "share" / "example-robot-data" / "robots" / "panda_description"
    assert (found / "urdf" / "panda.urdf").is_file()
    with pytest.raises(SvhdescError, match="here: python:no_such_folder_h4/x: no installed Python package or"):
        resolve_path("python:no_such_folder_h4/x", tmp_path, "here")


def test_resolving_a_python_path_imports_nothing() -> None:
    """Seeded fault: find_spec("cmeel.prefix") imports cmeel, whose import leaves a temporary folder that Python
    reports at exit ("Implicitly cleaning up <TemporaryDirectory ...>")."""
    code = (
        "import sys; from pathlib import Path; from svhdesc.core.settings.config import resolve_path; "
        f"resolve_path({ROBOTS + '/ur_description'!r}, Path('.'), 'x'); "
        "assert 'cmeel' not in sys.modules, 'cmeel imported'"
    )
    result = subprocess.run(
        [sys.executable, "-W", "error", "-c", code], cwd=REPO, capture_output=True, text=True, check=False
    )
    assert result.returncode == 0 and result.stderr == "", result.stderr


# --- package:/// --------------------------------------------------------------------------------------------


def test_package_uris_with_an_empty_authority_resolve_as_pinocchio_does(tmp_path: Path) -> None:
    """Talos' package:///example-robot-data/robots/... is package://example-robot-data/robots/... (pinocchio joins
    what follows "package://" to a package folder). Seeded fault: the old partition named package '' and advised
    `--package =DIR`, which --package refuses."""
    packages = {"pkg": tmp_path}
    assert resolve_uri("package:///pkg/meshes/a.stl", packages, "x") == tmp_path / "meshes" / "a.stl"
    assert resolve_uri("package:///pkg/a.stl", packages, "x") == resolve_uri("package://pkg/a.stl", packages, "x")
    for bad in ("package:///", "package:///pkg", "package://"):
        with pytest.raises(SvhdescError) as caught:
            resolve_uri(bad, packages, "robot.urdf")
        assert "needs package://NAME/PATH" in str(caught.value) and "--package =" not in str(caught.value)


def test_a_urdf_with_empty_authority_meshes_reads(tmp_path: Path) -> None:
    (tmp_path / "pkg" / "meshes").mkdir(parents=True)
    (tmp_path / "pkg" / "meshes" / "a.stl").write_bytes(b"solid a\nendsolid a\n")
    text = (
        '<robot name="r"><link name="a"><visual><geometry><mesh filename="package:///pkg/meshes/a.stl"/>'
        "</geometry></visual></link></robot>"
    )
    robot = read_urdf(etree.fromstring(text), {"pkg": tmp_path / "pkg"}, tmp_path / "r.urdf")
    assert robot.links[0].visuals[0].mesh == str((tmp_path / "pkg" / "meshes" / "a.stl").resolve())


# --- arm.joints alone ---------------------------------------------------------------------------------------


def test_arm_joints_alone_mean_the_arm_is_there(tmp_path: Path) -> None:
    """Seeded fault: `enabled` defaulting to false again fails this build with "nothing drives it"."""
    source = project(tmp_path)
    (source / "mini.yaml").write_text(NO_HAND.replace("arm: {enabled: true, ", "arm: {"))
    assert load_config(source / "mini.yaml").variants["mini"].settings.arm.active
    build(source / "mini.yaml", tmp_path / "out")
    assert len(urdf(tmp_path / "out").findall("transmission")) == 2


def test_an_arm_switched_off_is_named_as_the_way_out(tmp_path: Path) -> None:
    source = project(tmp_path)
    (source / "mini.yaml").write_text(NO_HAND.replace("arm: {enabled: true, ", "arm: {enabled: false, "))
    assert not load_config(source / "mini.yaml").variants["mini"].settings.arm.active
    error = fails_cleanly(None, "build", "--config", str(source / "mini.yaml"), "--out", str(tmp_path / "o"), match="")
    assert "nothing drives it" in error and f"arm.enabled is false at {source / 'mini.yaml'}:1: set it true" in error


def test_an_undriven_joint_names_the_keys_that_would_drive_it(tmp_path: Path) -> None:
    source = project(tmp_path)
    (source / "mini.yaml").write_text(
        NO_HAND.replace("joints: [right_hand_A, right_hand_j2]", "joints: [right_hand_A]")
    )
    error = fails_cleanly(None, "build", "--config", str(source / "mini.yaml"), "--out", str(tmp_path / "o"), match="")
    assert "joint right_hand_j2: is neither" in error and "list it in arm.joints" in error and "coupled joint" in error
