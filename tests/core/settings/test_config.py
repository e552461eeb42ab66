"""Config over code: contact model, explicit inertials, hardware interface, package lookup."""

from __future__ import annotations

from pathlib import Path

import pytest
import yaml
from lxml import etree

from svhdesc.core.source.packages import package_map, resolve_uri
from svhdesc.errors import SvhdescError
from tests.support import REPO, exported, run_cli


def build_with(tmp_path: Path, overrides: dict) -> tuple[etree._ElementTree, etree._ElementTree]:
    """The URDF and the MJCF the build makes of the right hand under ``overrides`` (tests/support.py ``exported``:
    the build's pipeline and exporters in this process, without the outputs it samples in MuJoCo)."""
    config = {
        "extends": str(REPO / "config" / "svhdesc.yaml"),
        **overrides,
        "variants": {"hand": {"xacro": str(REPO / "xacro" / "svh_hand.urdf.xacro"), "args": {"side": "right"}}},
    }
    path = tmp_path / "custom.yaml"
    path.write_text(yaml.safe_dump(config))
    urdf, mjcf = exported(path, "{robot}.urdf", "{robot}.xml").values()
    return etree.ElementTree(etree.fromstring(urdf)), etree.ElementTree(etree.fromstring(mjcf))


@pytest.mark.parametrize(
    ("model", "condim", "mu"), [("point", "1", 0.0), ("hard_finger", "3", 0.7), ("soft_finger", "4", 0.7)]
)
def test_grasp_contact_model_sets_condim_and_gazebo_friction(
    tmp_path: Path, model: str, condim: str, mu: float
) -> None:
    urdf, mjcf = build_with(tmp_path, {"contact": {"model": model, "sliding": 0.7, "torsional": 0.02}})
    tip = mjcf.find(".//body[@name='right_hand_t']/geom[@class='collision']")
    assert tip.get("condim") == condim
    palm = mjcf.find(".//body[@name='right_hand_e1']/geom[@class='collision']")
    assert palm.get("condim") == "3"
    assert float(urdf.find("gazebo[@reference='right_hand_t']/mu1").text) == mu
    torsional = urdf.find("gazebo[@reference='right_hand_t']/collision/surface/friction/torsional/coefficient")
    assert (torsional is not None) == (model == "soft_finger")


def test_explicit_inertial_wins_and_effort_interface(tmp_path: Path) -> None:
    inertial = {"mass": 0.05, "com": [0.01, 0.0, 0.0], "inertia": [1e-5, 0.0, 0.0, 2e-5, 0.0, 2e-5]}
    urdf, mjcf = build_with(
        tmp_path, {"mass": {"inertials": {"right_hand_t": inertial}}, "transmissions": {"interface": "effort"}}
    )
    link = urdf.find("link[@name='right_hand_t']/inertial")
    assert float(link.find("mass").get("value")) == 0.05
    assert float(link.find("inertia").get("iyy")) == 2e-5
    interfaces = {e.text for e in urdf.findall("transmission/joint/hardwareInterface")}
    assert interfaces == {"hardware_interface/EffortJointInterface"}
    assert len(urdf.findall("transmission")) == 9


def test_packages_come_from_ros_package_path_and_explicit_map(tmp_path: Path) -> None:
    (tmp_path / "ws" / "my_pkg").mkdir(parents=True)
    (tmp_path / "ws" / "my_pkg" / "package.xml").write_text("<package/>")
    found = package_map({}, env={"ROS_PACKAGE_PATH": str(tmp_path / "ws")})
    assert found["my_pkg"] == (tmp_path / "ws" / "my_pkg").resolve()
    assert resolve_uri("package://my_pkg/meshes/a.stl", found, "x") == found["my_pkg"] / "meshes/a.stl"
    override = package_map({"my_pkg": tmp_path}, env={"ROS_PACKAGE_PATH": str(tmp_path / "ws")})
    assert override["my_pkg"] == tmp_path.resolve()
    with pytest.raises(SvhdescError, match="unknown package 'nope'"):
        resolve_uri("package://nope/a.stl", found, "file.xacro")


def test_unknown_config_key_is_refused(tmp_path: Path) -> None:
    # A config that is valid but for the misspelt key: the refusal can only come from that key.
    variant = {"xacro": str(REPO / "xacro" / "svh_hand.urdf.xacro"), "args": {"side": "right"}}
    good = {"extends": str(REPO / "config" / "svhdesc.yaml"), "contact": {"model": "point"}, "variants": {"v": variant}}
    path = tmp_path / "good.yaml"
    path.write_text(yaml.safe_dump(good))
    assert run_cli("list", "--config", str(path)).returncode == 0
    path = tmp_path / "bad.yaml"
    path.write_text(yaml.safe_dump({**good, "contact": {"modle": "point"}}))
    result = run_cli("build", "--config", str(path), "--out", str(tmp_path / "out"), in_process=True)
    assert result.returncode == 2
    assert result.stderr.startswith(f"error: {path}:") and "['modle']" in result.stderr, result.stderr
    assert not (tmp_path / "out").exists()
