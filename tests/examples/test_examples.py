"""The example robots that are not the SVH: the vendor UR5 alone (no hand, no couplings) and the xArm6 with its
gripper from the pybullet wheel (one drive joint, five followers, invalid vendor inertias recomputed). Each
builds into a temporary folder, validates (exit 0, what does not apply listed as skipped) and loads in every
loader."""

from __future__ import annotations

import json
import re
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest
import yaml
from lxml import etree

import svhdesc
from svhdesc.loaders import couplings
from svhdesc.validate.handsim import hand_parts
from svhdesc.validate.options import Options
from svhdesc.validate.pair import load_pair
from svhdesc.validate.range_of_motion import check_range_of_motion
from tests.support import REPO, VENDOR_UR, run_cli

EXAMPLES = REPO / "examples"
UR5 = EXAMPLES / "ur5" / "ur5.yaml"
XARM = EXAMPLES / "xarm6_gripper" / "xarm6_gripper.yaml"
XARM_FOLLOWERS = {
    "left_finger_joint",
    "left_inner_knuckle_joint",
    "right_outer_knuckle_joint",
    "right_finger_joint",
    "right_inner_knuckle_joint",
}
NOT_AN_SVH = {"collision_fidelity", "contact_stability", "fingertip_force", "grasps"}  # the SVH's facts
POSITION_SERVOS = {"velocity_tracking"}  # every joint on a position servo
SKIPPED = {
    "ur5": NOT_AN_SVH | POSITION_SERVOS | {"load_limits", "coupling_tracking", "coupling_spec", "limits"},  # driven
    "xarm6_gripper": NOT_AN_SVH | POSITION_SERVOS,  # its gripper is driven end to end and loaded like any hand
}

pytestmark = pytest.mark.slow  # each robot's build and validate take tens of seconds


@pytest.fixture(scope="module")
def ur5(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, subprocess.CompletedProcess[str]]:
    """(the built variant's folder, the build's result)."""
    if not VENDOR_UR.is_dir():
        pytest.skip(f"no vendor ur_description at {VENDOR_UR}")
    out = tmp_path_factory.mktemp("ur5") / "out"
    result = run_cli("build", "--config", str(UR5), "--out", str(out), "--package", f"ur_description={VENDOR_UR}")
    assert result.returncode == 0, result.stderr
    return out / "ur5", result


@pytest.fixture(scope="module")
def xarm(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, subprocess.CompletedProcess[str]]:
    pytest.importorskip("pybullet_data")
    out = tmp_path_factory.mktemp("xarm") / "out"
    result = run_cli("build", "--config", str(XARM), "--out", str(out))  # the wheel's folder: found, not passed
    assert result.returncode == 0, result.stderr
    return out / "xarm6_gripper", result


@pytest.fixture(params=["ur5", "xarm6_gripper"])
def example(request: pytest.FixtureRequest) -> tuple[str, Path, Path]:
    """(name, config, built folder)."""
    name = request.param
    folder, _ = request.getfixturevalue("ur5" if name == "ur5" else "xarm")
    return name, UR5 if name == "ur5" else XARM, folder


def urdf_masses(folder: Path) -> float:
    root = etree.parse(str(folder / f"{folder.name}.urdf")).getroot()
    return sum(float(m.get("value")) for m in root.iterfind("link/inertial/mass"))


def movable(folder: Path) -> list[str]:
    root = etree.parse(str(folder / f"{folder.name}.urdf")).getroot()
    return [j.get("name") for j in root.iter("joint") if j.get("type") in ("revolute", "continuous", "prismatic")]


def test_ur5_alone_needs_no_hand_section(ur5: tuple[Path, subprocess.CompletedProcess[str]]) -> None:
    written = yaml.safe_load(UR5.read_text())
    assert "hand" not in written and "coupling" not in written  # no dummy hand, no spec
    folder, _ = ur5
    root = etree.parse(str(folder / "ur5.urdf")).getroot()
    assert root.find(".//mimic") is None
    assert [t.findtext("joint[1]/hardwareInterface") for t in root.iter("transmission")] == [
        "hardware_interface/PositionJointInterface"
    ] * 6


def test_xarm_couples_its_own_joints_and_recomputes_invalid_inertias(
    xarm: tuple[Path, subprocess.CompletedProcess[str]],
) -> None:
    folder, result = xarm
    root = etree.parse(str(folder / "xarm6_gripper.urdf")).getroot()
    mimics = {j.get("name"): j.find("mimic").get("joint") for j in root.iter("joint") if j.find("mimic") is not None}
    assert mimics == dict.fromkeys(XARM_FOLLOWERS, "drive_joint")
    # The vendor's link2 and link3 break the triangle inequality: replaced, one warning each; the rest kept.
    replaced = sorted(
        line.split()[2].rstrip(":") for line in result.stderr.splitlines() if "recomputed as a cylinder" in line
    )
    assert replaced == ["link2", "link3"], result.stderr
    for link in root.iter("link"):
        inertia = link.find("inertial/inertia")
        if inertia is None:
            continue
        v = {k: float(x) for k, x in inertia.attrib.items()}
        moments = np.linalg.eigvalsh(
            [[v["ixx"], v["ixy"], v["ixz"]], [v["ixy"], v["iyy"], v["iyz"]], [v["ixz"], v["iyz"], v["izz"]]]
        )
        assert moments[0] > 0 and moments[0] + moments[1] >= moments[2] * (1 - 1e-9), link.get("name")
    link2 = root.find("link[@name='link2']/inertial")
    assert float(link2.find("mass").get("value")) == 1.71  # the vendor's mass, a fitted distribution
    assert float(link2.find("inertia").get("ixx")) != 0.0248674
    assert float(root.find("link[@name='link1']/inertial/inertia").get("ixx")) == 0.00539427  # valid: kept
    # A hand without prefix: its controller is `hand_controller` (the ROS node's name for it too).
    controllers = yaml.safe_load((folder / "config" / "moveit_controllers.yaml").read_text())["controller_list"]
    assert controllers[0]["name"] == "hand_controller" and controllers[0]["joints"] == ["drive_joint"]


def test_example_validates(example: tuple[str, Path, Path], tmp_path: Path) -> None:
    """Every check that applies passes (exit 0); those that do not are skipped and listed with why."""
    name, config, folder = example
    report = tmp_path / "report.json"
    result = run_cli(
        "validate", "--config", str(config), "--out", str(folder.parent), "--json", str(report), in_process=True
    )
    assert result.returncode == 0, result.stdout + result.stderr
    checks = {c["name"]: c for c in json.loads(report.read_text())["variants"][0]["checks"]}
    assert {n for n, c in checks.items() if c["status"] == "skipped"} == SKIPPED[name]
    assert all(c["status"] == "pass" for n, c in checks.items() if n not in SKIPPED[name])
    assert all(checks[n]["detail"] for n in SKIPPED[name])  # each says why
    assert "skipped (not applicable): " in result.stdout
    assert f"{len(SKIPPED[name])} skipped as not applicable" in result.stdout


def test_example_loads_in_every_loader(example: tuple[str, Path, Path]) -> None:
    """Each engine loads the built folder, weighs what the URDF says and holds the couplings as constraints."""
    _, _, folder = example
    mass = urdf_masses(folder)
    followers = {c.joint for c in couplings(str(folder))}
    leaders = [j for j in movable(folder) if j not in followers]

    mujoco_model = svhdesc.load_mujoco(str(folder))
    assert mujoco_model.neq == len(followers)
    assert float(mujoco_model.body_mass.sum()) == pytest.approx(mass, abs=1e-6)

    robot = svhdesc.load_pinocchio(str(folder))
    assert robot.model.nq == len(leaders)  # followers are mimic joints
    assert sum(i.mass for i in robot.model.inertias) == pytest.approx(mass, abs=1e-6)

    p = pytest.importorskip("pybullet")
    bullet = svhdesc.load_pybullet(str(folder))
    try:
        assert set(bullet.constraints) == followers
        total = sum(
            p.getDynamicsInfo(bullet.body, i, physicsClientId=bullet.client)[0] for i in range(-1, len(bullet.joints))
        )
        assert total == pytest.approx(mass, abs=1e-6)
    finally:
        p.disconnect(physicsClientId=bullet.client)

    drake = svhdesc.load_drake(str(folder))
    assert drake.plant.num_constraints() == len(followers)
    assert drake.plant.num_positions() == len(leaders) + len(followers)

    skeleton = svhdesc.load_dart(str(folder))
    assert skeleton.getMass() == pytest.approx(mass, abs=1e-6)
    assert skeleton.getNumDofs() == len(leaders) + len(followers)


def test_example_arm_group_is_the_chain_of_its_arm_joints(example: tuple[str, Path, Path]) -> None:
    """MoveIt's arm group spans exactly the robot's arm joints: base_link..tool0 where the robot has them
    (ROS-Industrial's names, the UR5), else the first arm joint's parent to the last one's child (the xArm). The
    UR5 alone plans its arm only: no hand group, no end effector, its controller the arm's alone."""
    name, config, folder = example
    srdf = etree.parse(str(folder / "config" / f"{folder.name}.srdf")).getroot()
    chain = srdf.find("group[@name='manipulator']/chain")
    assert (chain.get("base_link"), chain.get("tip_link")) == (
        ("base_link", "tool0") if name == "ur5" else ("link_base", "link6")
    )
    groups = [g.get("name") for g in srdf.iterfind("group")]
    assert groups == (["manipulator"] if name == "ur5" else ["manipulator", "hand", "arm_hand"])
    assert {s.get("group") for s in srdf.iterfind("group_state")} == {groups[-1]}
    controllers = yaml.safe_load((folder / "config" / "moveit_controllers.yaml").read_text())["controller_list"]
    assert [c["name"] for c in controllers] == (
        ["scaled_pos_joint_traj_controller"]
        if name == "ur5"
        else ["hand_controller", "scaled_pos_joint_traj_controller"]
    )
    urdf = etree.parse(str(folder / f"{folder.name}.urdf")).getroot()
    up = {j.find("child").get("link"): j for j in urdf.iterfind("joint")}
    link, spanned = chain.get("tip_link"), []
    while link != chain.get("base_link"):
        joint = up[link]  # a KeyError: the base is not above the tip
        if joint.get("type") != "fixed":
            spanned.append(joint.get("name"))
        link = joint.find("parent").get("link")
    assert spanned[::-1] == yaml.safe_load(config.read_text())["arm"]["joints"]
    effector = srdf.find("end_effector")
    assert effector is None if name == "ur5" else effector.get("parent_link") == chain.get("tip_link")


def test_xarm_gripper_is_driven_end_to_end_and_a_weak_drive_fails(
    xarm: tuple[Path, subprocess.CompletedProcess[str]], tmp_path: Path
) -> None:
    """range_of_motion drives the configured hand of any robot: the gripper's one channel, end to end with its five
    followers; a drive too weak to move the linkage stops short and is named."""
    folder, _ = xarm
    name = folder.name
    pair = load_pair(folder / f"{name}.urdf", folder / f"{name}.xml", config_path=XARM)
    (check,) = check_range_of_motion(pair, Options())
    assert check.status == "pass", check.detail
    # load_limits pushes the configured fingertips (hand.fingertips), not an SVH's distal links
    assert sorted(pair.model.body(b).name for b in hand_parts(pair).tips) == ["left_finger", "right_finger"]
    (entry,) = check.data["channels"].values()
    assert list(check.data["channels"]) == ["drive_joint"] and set(entry["followers"]) == XARM_FOLLOWERS
    assert entry["fraction"] > 0.99
    weak = tmp_path / name
    shutil.copytree(folder, weak)
    mjcf = weak / f"{name}.xml"
    lines = mjcf.read_text().splitlines(keepends=True)
    force = re.compile(r'(actuatorfrcrange|forcerange)="-50 50"')
    drive = [i for i, line in enumerate(lines) if 'name="drive_joint"' in line and force.search(line)]
    assert len(drive) == 2  # the drive joint (actuatorfrcrange) and its servo (forcerange)
    for i in drive:
        lines[i] = force.sub(r'\1="-0.001 0.001"', lines[i])
    mjcf.write_text("".join(lines))
    (check,) = check_range_of_motion(load_pair(weak / f"{name}.urdf", mjcf, config_path=XARM), Options())
    assert check.status == "fail" and "drive_joint stops at" in check.detail, check.detail
