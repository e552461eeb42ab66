"""A continuous joint driven by a velocity servo (``joints.NAME.servo: velocity``, set with ``svhdesc init --joint
wheel.servo=velocity``: TIAGo's wheels) through every output, each read with its consumer's own parser: MuJoCo (a
``<velocity>`` actuator, kv = effort / (0.1 x velocity), still at home), the URDF and ROS 1 (a VelocityJointInterface
transmission, velocity_controllers' group, left out of the trajectory controller, MoveIt's groups and the
connector), ROS 2 (xacro's expansion: a velocity command interface; the velocity group spawned active, its package
depended on), USD (usd-core: a drive with damping only, a target velocity). The robot: tests/support.py ``wheeled``.
Each test names its seeded fault; ``test_refused_where_it_does_not_fit`` the refusals.
"""

from __future__ import annotations

import re
from pathlib import Path

import mujoco
import pytest
import yaml
from lxml import etree

import xacro
from svhdesc.model import velocity_servos
from tests.compiler.export.test_ros2_files import component_errors
from tests.support import fails_cleanly, wheeled

KV = 5.0 / (0.1 * 3.0)  # effort / (0.1 x velocity) of WHEELED_URDF's wheel


@pytest.fixture(scope="module")
def folder() -> Path:
    return wheeled()


def _yaml(folder: Path, name: str) -> dict:
    return yaml.safe_load((folder / name).read_text())


def test_mjcf_a_velocity_actuator_still_at_home(folder: Path) -> None:
    """Seeded fault: the MJCF exporter writing the velocity servo as a <position> one (kp = kv) -> no velocity servo
    in the model."""
    model = mujoco.MjModel.from_xml_path(str(folder / "wheeled.xml"))
    assert velocity_servos(model) == {"wheel"}
    wheel = model.actuator("wheel")
    assert wheel.gainprm[0] == pytest.approx(KV) and wheel.biasprm[2] == pytest.approx(-KV)
    assert wheel.ctrlrange.tolist() == [-3.0, 3.0] and wheel.forcerange.tolist() == [-5.0, 5.0]
    assert model.key("home").ctrl[wheel.id] == 0.0 and model.actuator("elbow").biasprm[1] < 0  # a position servo


def test_urdf_and_ros1_files(folder: Path) -> None:
    """Seeded faults: the transmission keeping the section's PositionJointInterface; export_ros_controllers without
    the velocity group; moveit.arm_joints keeping the wheel (the trajectory controller claims it)."""
    urdf = etree.parse(str(folder / "wheeled.urdf"))
    interfaces = {
        t.find("joint").get("name"): t.find("joint/hardwareInterface").text for t in urdf.iterfind("transmission")
    }
    assert interfaces == {
        "wheel": "hardware_interface/VelocityJointInterface",
        "elbow": "hardware_interface/PositionJointInterface",
    }
    controllers = _yaml(folder, "config/ros_controllers.yaml")
    assert controllers["forward_velocity_controller"] == {
        "type": "velocity_controllers/JointGroupVelocityController",
        "joints": ["wheel"],
    }
    assert controllers["scaled_pos_joint_traj_controller"]["joints"] == ["elbow"]
    assert [j["joints"] for j in _yaml(folder, "config/moveit_controllers.yaml")["controller_list"]] == [["elbow"]]
    assert [j["name"] for j in _yaml(folder, "config/connector.yaml")["joints"]] == ["elbow"]
    srdf = etree.parse(str(folder / "config/wheeled.srdf"))
    assert [j.get("name") for j in srdf.iterfind("group_state/joint")] == ["elbow"]


def test_ros2_files(folder: Path) -> None:
    """xacro expands the ROS 2 URDF with the wheel commanded in velocity (the component parser's checks pass).
    Seeded faults: _interfaces giving every actuated joint a position command interface; export_controllers without
    the velocity group; the launch file spawning it not at all."""
    document = xacro.process_file(
        str(folder / "ros2/urdf/wheeled.urdf.xacro"), mappings={"hardware": "mock", "controllers": "/c.yaml"}
    )
    urdf = etree.fromstring(document.toxml().encode())
    assert component_errors(urdf) == []
    wheel = urdf.find("ros2_control/joint[@name='wheel']")
    assert [c.get("name") for c in wheel.iterfind("command_interface")] == ["velocity"]
    controllers = _yaml(folder, "ros2/config/ros2_controllers.yaml")
    manager = controllers["controller_manager"]["ros__parameters"]
    assert manager["forward_velocity_controller"] == {"type": "velocity_controllers/JointGroupVelocityController"}
    assert controllers["forward_velocity_controller"]["ros__parameters"] == {"joints": ["wheel"]}
    trajectory = [n for n, v in manager.items() if isinstance(v, dict) and "Trajectory" in v["type"]]
    assert [controllers[n]["ros__parameters"]["joints"] for n in trajectory] == [["elbow"]]
    launch = (folder / "ros2/launch/sim.launch.py").read_text()
    spawned = re.search(r"^SPAWN = (\[.*\])$", launch, re.MULTILINE)
    assert spawned and "forward_velocity_controller" in spawned.group(1)
    assert "<exec_depend>velocity_controllers</exec_depend>" in (folder / "ros2/package.xml").read_text()


def test_usd_drive_with_damping_only(folder: Path) -> None:
    """usd-core reads the wheel's angular drive: stiffness 0, damping kv per degree, a target velocity, the effort as
    its force limit. Seeded fault: _drive given the servo's kv as its stiffness."""
    from pxr import Usd, UsdPhysics

    from svhdesc.compiler.export.usd import DEG

    stage = Usd.Stage.Open(str(folder / "wheeled.usda"))
    prims = {p.GetName(): p for p in stage.Traverse() if p.IsA(UsdPhysics.RevoluteJoint)}
    drive = UsdPhysics.DriveAPI(prims["wheel"], "angular")
    assert drive.GetStiffnessAttr().Get() == 0.0 and drive.GetMaxForceAttr().Get() == 5.0
    assert drive.GetDampingAttr().Get() == pytest.approx(KV / DEG, rel=1e-6)
    assert drive.GetTargetVelocityAttr().HasAuthoredValue() and not drive.GetTargetPositionAttr().HasAuthoredValue()
    assert UsdPhysics.DriveAPI(prims["elbow"], "angular").GetStiffnessAttr().Get() > 0


def test_refused_where_it_does_not_fit(folder: Path) -> None:
    """joints.NAME.servo: velocity on a joint with limits, or on one no arm servo drives (the wheel left out of
    arm.joints), is one error line at the setting (seeded fault: _check_servo_keys not called: the elbow builds with
    a position servo; the wheel is refused as undriven, the setting not named)."""
    config = folder.parents[1] / "wheeled.yaml"
    text = config.read_text()
    on_elbow = text.replace("  elbow:\n    damping", "  elbow:\n    servo: velocity\n    damping", 1)
    no_wheel = re.sub(r"kp: \[[^,\]]*, ", "kp: [", text.replace("joints: [wheel, elbow]", "joints: [elbow]"))
    for name, edited, why in (("elbow", on_elbow, "elbow is not continuous"), ("wheel", no_wheel, "wheel is not in")):
        bad, out = folder.parents[1] / f"bad_{name}.yaml", folder.parents[1] / f"out_{name}"
        bad.write_text(edited)
        rows = edited.splitlines()
        line = next(n for n, row in enumerate(rows, 1) if row == f"  {name}:" and rows[n] == "    servo: velocity") + 1
        error = fails_cleanly(out, "build", "--config", str(bad), "--out", str(out), match="servo: velocity")
        assert f"{bad}:{line}: joints.{name}.servo" in error and why in error, error


def test_the_build_names_each_servo_s_own_gain(folder: Path) -> None:
    """Where the build says what drives a joint (its refusal of a model that diverges), a velocity servo's gain is
    its kv and a position servo's its kp. Seeded fault: every servo's gain called kp -> the wheel's line says kp."""
    from svhdesc.compiler.probes.stability import _strongest

    model = mujoco.MjModel.from_xml_path(str(folder / "wheeled.xml"))
    wheel, elbow = (int(model.jnt_dofadr[model.joint(name).id]) for name in ("wheel", "elbow"))
    assert f"(kv {KV:.4g}, force limit 5)" in _strongest(model, wheel)
    assert "(kp " in _strongest(model, elbow)
