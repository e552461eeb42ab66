"""The ROS 2 files of each variant (``ros2/``), read from the session's build and checked with real parsers:
catkin_pkg's package.xml parser (format 3), xacro (each hardware plugin), the yaml against the expanded URDF,
MuJoCo for the ROS 2 MJCF, and Python's compiler for the launch files.

ros2_control itself (hardware_interface's component parser, the controller manager), MoveIt 2, Gazebo and
``launch``/``launch_ros`` are not on PyPI and do not run here: ``component_errors`` restates the component parser's
checks (ros2_control Jazzy, hardware_interface/src/component_parser.cpp, parse_control_resources_from_urdf), and
the launch files are evaluated against recording stand-ins of the launch API (see docs/ros2.md).
Each checker is shown to fail on a seeded fault in the same test.
"""

from __future__ import annotations

import ast
import copy
import functools
import io
import sys
import types
from pathlib import Path
from typing import Any

import pytest
import yaml
from catkin_pkg.package import parse_package_string
from lxml import etree

import xacro
from svhdesc.compiler.export.ros2_control import PLUGINS
from svhdesc.model import DRIVER_CHANNELS, ROS2_UPDATE_RATE
from tests.support import VARIANTS, built

# joint_trajectory_controller's parameters (ros2_controllers, joint_trajectory_controller_parameters.yaml).
JTC_PARAMETERS = {
    "joints",
    "command_joints",
    "command_interfaces",
    "state_interfaces",
    "speed_scaling",
    "allow_partial_joints_goal",
    "interpolate_from_desired_state",
    "allow_integration_in_goal_trajectories",
    "set_last_command_interface_value_as_state_on_activation",
    "action_monitor_rate",
    "interpolation_method",
    "allow_nonzero_velocity_at_trajectory_end",
    "cmd_timeout",
    "gains",
    "constraints",
}
# forward_command_controller's (forward_command_controller_parameters.yaml); JointGroupPositionController fixes
# interface_name to position.
FORWARD_PARAMETERS = {"joints", "interface_name"}
FORWARD_TYPE = "position_controllers/JointGroupPositionController"
SIDE = {"svh_right": "Right_Hand", "ur5_svh_right": "Right_Hand", "svh_left": "Left_Hand"}
CONTROLLER = {"svh_right": "right_hand", "ur5_svh_right": "right_hand", "svh_left": "left_hand"}
ARM = ("shoulder_pan_joint", "shoulder_lift_joint", "elbow_joint", "wrist_1_joint", "wrist_2_joint", "wrist_3_joint")


def _folder(variant: str) -> Path:
    return built() / variant / "ros2"


@functools.cache
def _expand(variant: str, hardware: str) -> etree._Element:
    """xacro's own processing of the generated URDF xacro (as the launch files run it); callers must not change it."""
    path = _folder(variant) / "urdf" / f"{variant}.urdf.xacro"
    document = xacro.process_file(str(path), mappings={"hardware": hardware, "controllers": "/ros2_controllers.yaml"})
    return etree.fromstring(document.toxml().encode())


def _controllers(variant: str) -> dict[str, Any]:
    return yaml.safe_load((_folder(variant) / "config" / "ros2_controllers.yaml").read_text())


def component_errors(urdf: etree._Element) -> list[str]:
    """The component parser's checks of each <ros2_control> joint against the URDF (Jazzy)."""
    joints = {j.get("name"): j for j in urdf.iterfind("joint")}
    errors = []
    for system in urdf.iterfind("ros2_control"):
        names = [j.get("name") for j in system.iterfind("joint")]
        for joint in system.iterfind("joint"):
            name, mimic = joint.get("name"), joint.get("mimic")
            described = joints.get(name)
            if described is None:
                errors.append(f"Joint '{name}' not found in URDF")
                continue
            coupled = described.find("mimic")
            if coupled is None and mimic == "true":
                errors.append(f"Joint '{name}' has no mimic information in the URDF.")
            if coupled is not None and mimic != "false":
                if joint.find("command_interface") is not None:
                    errors.append(f"Joint '{name}': activated mimic joints cannot have command interfaces")
                if coupled.get("joint") not in names:
                    errors.append(f"Mimic joint '{coupled.get('joint')}' not found in <ros2_control> tag")
            if described.get("type") == "fixed":
                errors.append(f"Joint '{name}' is of type 'fixed'")
    return errors


def _interfaces(urdf: etree._Element, kind: str) -> dict[str, set[str]]:
    return {
        j.get("name"): {i.get("name") for i in j.iterfind(f"{kind}_interface")}
        for j in urdf.iterfind("ros2_control/joint")
    }


@pytest.mark.parametrize("variant", VARIANTS)
def test_package_xml_is_format_3_ament_cmake(variant: str) -> None:
    text = (_folder(variant) / "package.xml").read_text()
    package = parse_package_string(text)
    package.evaluate_conditions({"ROS_VERSION": "2"})
    package.validate()
    assert package.package_format == 3 and package.name == variant
    assert [d.name for d in package.buildtool_depends] == ["ament_cmake"]
    assert package.get_build_type() == "ament_cmake"
    assert {"robot_state_publisher", "xacro", "controller_manager"} <= {d.name for d in package.exec_depends}
    cmake = (_folder(variant) / "CMakeLists.txt").read_text()
    assert f"project({variant} NONE)" in cmake and "ament_package()" in cmake
    # Seeded fault: a package.xml that names no build type is a catkin package to colcon.
    broken = parse_package_string(text.replace("<build_type>ament_cmake</build_type>", ""))
    assert broken.get_build_type() == "catkin"


# Every variant with the mock hardware; the other plugins on the variant with a hand and an arm.
EXPANSIONS = [(v, "mock") for v in VARIANTS] + [(v, h) for v in VARIANTS if "ur5" in v for h in ("mujoco", "gazebo")]


@pytest.mark.parametrize(("variant", "hardware"), EXPANSIONS)
def test_ros2_control_expands_and_passes_the_component_parsers_checks(variant: str, hardware: str) -> None:
    urdf = _expand(variant, hardware)
    systems = urdf.findall("ros2_control")
    assert len(systems) == 1 and systems[0].findtext("hardware/plugin") == PLUGINS[hardware]
    assert component_errors(urdf) == []
    commands = {name: kinds for name, kinds in _interfaces(urdf, "command").items() if kinds}
    mimic = {j.get("name") for j in urdf.iterfind("joint") if j.find("mimic") is not None}
    assert set(commands) == {f"{SIDE[variant]}_{c}" for c in DRIVER_CHANNELS} | (
        set(ARM) if "ur5" in variant else set()
    )
    assert {j.get("name") for j in systems[0].iterfind("joint[@mimic='true']")} == mimic and len(mimic) == 11
    assert all(kinds == {"position"} for kinds in commands.values())
    if hardware == "mock" and "ur5" in variant:  # a URDF parser of its own: the non-mimic joints are the commanded
        yourdfpy = pytest.importorskip("yourdfpy")
        parsed = yourdfpy.URDF.load(io.BytesIO(etree.tostring(urdf)), load_meshes=False)
        assert parsed.validate() and set(parsed.actuated_joint_names) == set(commands)
    gazebo = urdf.findall("gazebo/plugin[@filename='gz_ros2_control-system']")
    assert len(gazebo) == (hardware == "gazebo")
    assert not urdf.findall("transmission") and not urdf.xpath("gazebo/plugin[contains(@filename, 'libgazebo')]")
    # Seeded faults the checker must catch: a command interface on a mimic joint, a joint the URDF lacks.
    broken = copy.deepcopy(urdf)
    etree.SubElement(broken.find("ros2_control/joint[@mimic='true']"), "command_interface", name="position")
    etree.SubElement(broken.find("ros2_control"), "joint", name="no_such_joint")
    assert len(component_errors(broken)) == 2


@pytest.mark.parametrize("variant", VARIANTS[:1])
def test_an_unknown_hardware_is_refused_by_xacro(variant: str) -> None:
    with pytest.raises(xacro.XacroException, match="hardware must be one of gazebo, mock, mujoco"):
        _expand(variant, "gazebo_classic")


def controller_errors(parameters: dict[str, Any], urdf: etree._Element) -> list[str]:
    """Each controller the manager declares: a JTC or a position group whose parameters the controller knows, over
    joints and interfaces the ros2_control system provides."""
    manager = parameters["controller_manager"]["ros__parameters"]
    commands, states = _interfaces(urdf, "command"), _interfaces(urdf, "state")
    errors = []
    for name, declared in manager.items():
        if not isinstance(declared, dict) or declared["type"].startswith("joint_state_broadcaster/"):
            continue
        controller = parameters[name]["ros__parameters"]
        if declared["type"] == FORWARD_TYPE:
            errors += [f"{name}: unknown parameter {key}" for key in set(controller) - FORWARD_PARAMETERS]
            errors += [
                f"{name}: {j} has no position command"
                for j in controller["joints"]
                if "position" not in commands.get(j, set())
            ]
            continue
        errors += [f"{name}: unknown parameter {key}" for key in set(controller) - JTC_PARAMETERS]
        for joint in controller["joints"]:
            if not set(controller["command_interfaces"]) <= commands.get(joint, set()):
                errors.append(f"{name}: {joint} has no command interface {controller['command_interfaces']}")
            if not set(controller["state_interfaces"]) <= states.get(joint, set()):
                errors.append(f"{name}: {joint} lacks a state interface of {controller['state_interfaces']}")
        known = set(controller["joints"]) | {"goal_time", "stopped_velocity_tolerance"}
        errors += [f"{name}: constraints for {key}" for key in set(controller.get("constraints", {})) - known]
    return errors


@pytest.mark.parametrize("variant", VARIANTS)
def test_controllers_yaml_is_ros2_parameters_over_the_described_joints(variant: str) -> None:
    parameters, urdf = _controllers(variant), _expand(variant, "mock")
    manager = parameters["controller_manager"]["ros__parameters"]
    assert manager["update_rate"] == ROS2_UPDATE_RATE
    # The forward position controllers: ur_robot_driver's over the arm; the hand's, named after it beside an arm.
    hand_forward = (
        f"{CONTROLLER[variant]}_forward_position_controller" if "ur5" in variant else "forward_position_controller"
    )
    expected = {"joint_state_broadcaster", CONTROLLER[variant], hand_forward} | (
        {"scaled_joint_trajectory_controller", "forward_position_controller"} if "ur5" in variant else set()
    )
    assert {k for k, v in manager.items() if isinstance(v, dict)} == expected
    assert controller_errors(parameters, urdf) == []
    hand = parameters[CONTROLLER[variant]]["ros__parameters"]
    assert hand["joints"] == [f"{SIDE[variant]}_{c}" for c in DRIVER_CHANNELS]
    assert manager[hand_forward]["type"] == FORWARD_TYPE
    assert parameters[hand_forward]["ros__parameters"] == {"joints": hand["joints"]}
    if "ur5" in variant:
        assert parameters["forward_position_controller"]["ros__parameters"] == {"joints": list(ARM)}
    assert hand["allow_partial_joints_goal"] is True and "constraints" not in hand  # SCHUNK's: JTC defaults
    if "ur5" in variant:
        arm = parameters["scaled_joint_trajectory_controller"]["ros__parameters"]
        assert arm["joints"] == list(ARM) and arm["allow_partial_joints_goal"] is False
        assert arm["constraints"]["goal_time"] == 0.0 and arm["constraints"]["stopped_velocity_tolerance"] == 0.2
        assert all(arm["constraints"][j] == {"goal": 0.1, "trajectory": 0.2} for j in ARM)
    # Seeded faults: a ROS 1 joint name, an interface the system lacks, a parameter JTC does not have.
    broken = copy.deepcopy(parameters)
    controller = broken[CONTROLLER[variant]]["ros__parameters"]
    controller["joints"][0] = controller["joints"][0].lower()
    controller["state_interfaces"] = ["position", "acceleration"]
    controller["state_publish_rate"] = 50.0
    broken[hand_forward]["ros__parameters"]["joints"][-1] += "_x"
    broken[hand_forward]["ros__parameters"]["command_interfaces"] = ["position"]
    assert len(controller_errors(broken, urdf)) == 1 + 9 + 1 + 2


@pytest.mark.parametrize("variant", VARIANTS)
def test_moveit2_config_names_the_controllers_and_joints(variant: str) -> None:
    config, urdf = _folder(variant) / "config", _expand(variant, "mock")
    joints = {j.get("name"): j for j in urdf.iterfind("joint")}
    moveit = yaml.safe_load((config / "moveit_controllers.yaml").read_text())
    manager = moveit["moveit_simple_controller_manager"]
    parameters = _controllers(variant)
    for name in manager["controller_names"]:
        assert manager[name]["joints"] == parameters[name]["ros__parameters"]["joints"]
        assert (
            manager[name]["action_ns"] == "follow_joint_trajectory" and manager[name]["type"] == "FollowJointTrajectory"
        )
    srdf = etree.parse(str(config / f"{variant}.srdf"))
    assert {p.get("name") for p in srdf.iterfind("passive_joint")} == {
        n for n, j in joints.items() if j.find("mimic") is not None
    }
    assert {j.get("name") for j in srdf.iterfind("group/joint")} <= set(joints)
    assert {j.get("name") for j in srdf.iterfind("group_state/joint")} <= set(joints)
    limits = yaml.safe_load((config / "joint_limits.yaml").read_text())["joint_limits"]
    assert set(limits) <= set(joints) and f"{SIDE[variant]}_Pinky" in limits
    assert yaml.safe_load((config / "kinematics.yaml").read_text()) is not None or "ur5" not in variant


@pytest.mark.parametrize("variant", [v for v in VARIANTS if "ur5" in v])  # hand and arm; the others differ in names
def test_ros2_mujoco_model_has_the_ros2_control_joints(variant: str) -> None:
    mujoco = pytest.importorskip("mujoco")
    model = mujoco.MjModel.from_xml_path(str(_folder(variant) / "mujoco" / "scene.xml"))
    names = {model.joint(i).name for i in range(model.njnt)}
    urdf = _expand(variant, "mujoco")
    assert set(_interfaces(urdf, "state")) <= names
    assert {j.get("name") for j in urdf.iterfind("joint") if j.get("type") != "fixed"} == names


class _Recorded:
    """A stand-in of a launch API class or function: records how the launch file called it."""

    calls: list[tuple[str, tuple, dict]] = []

    def __init__(self, kind: str, *args: Any, **kwargs: Any) -> None:
        self.kind, self.args, self.kwargs = kind, args, kwargs
        _Recorded.calls.append((kind, args, kwargs))


# The launch API names the files may use, each in the module that has it in Jazzy.
LAUNCH_API = {
    "launch": {"LaunchDescription"},
    "launch.actions": {"DeclareLaunchArgument", "ExecuteProcess", "IncludeLaunchDescription"},
    "launch.conditions": {"LaunchConfigurationEquals", "IfCondition"},
    "launch.launch_description_sources": {"PythonLaunchDescriptionSource"},
    "launch.substitutions": {
        "Command",
        "EnvironmentVariable",
        "FindExecutable",
        "LaunchConfiguration",
        "PathJoinSubstitution",
        "PythonExpression",
    },
    "launch_ros.actions": {"Node"},
    "launch_ros.parameter_descriptions": {"ParameterValue"},
    "launch_ros.substitutions": {"FindPackageShare"},
    "moveit_configs_utils": {"MoveItConfigsBuilder"},
}


class _Builder(_Recorded):
    def __getattr__(self, name: str) -> Any:
        return lambda *args, **kwargs: _Builder(name, *args, **kwargs)


def _stand_ins(monkeypatch: pytest.MonkeyPatch) -> None:
    for module, names in LAUNCH_API.items():
        stub = types.ModuleType(module)
        for name in names:
            kind = _Builder if name == "MoveItConfigsBuilder" else _Recorded
            setattr(stub, name, lambda *a, _n=name, _k=kind, **k: _k(_n, *a, **k))
        monkeypatch.setitem(sys.modules, module, stub)


def _launch(variant: str, name: str, monkeypatch: pytest.MonkeyPatch) -> tuple[types.ModuleType, list]:
    path = _folder(variant) / "launch" / name
    source = path.read_text()
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.ImportFrom):
            assert {a.name for a in node.names} <= LAUNCH_API[node.module], node.module
    _stand_ins(monkeypatch)
    module = types.ModuleType(name)
    exec(compile(source, str(path), "exec"), module.__dict__)
    _Recorded.calls = []
    module.generate_launch_description()
    return module, _Recorded.calls


@pytest.mark.parametrize("variant", VARIANTS)
def test_launch_files_spawn_the_yaml_controllers_and_name_files_that_exist(
    variant: str, monkeypatch: pytest.MonkeyPatch
) -> None:
    share = built() / variant  # the package's share directory is the variant folder
    module, calls = _launch(variant, "sim.launch.py", monkeypatch)
    manager = _controllers(variant)["controller_manager"]["ros__parameters"]
    spawners = [k["arguments"] for kind, _, k in calls if kind == "Node" and k["executable"] == "spawner"]
    assert spawners[0][0] == "joint_state_broadcaster"
    assert sorted(a[0] for a in spawners) == sorted(name for name, value in manager.items() if isinstance(value, dict))
    # the forward position controllers are loaded inactive (spawner --inactive), the others active
    inactive = {a[0] for a in spawners if "--inactive" in a}
    assert inactive == {n for n, v in manager.items() if isinstance(v, dict) and v["type"] == FORWARD_TYPE} != set()
    arguments = {a[0]: k for kind, a, k in calls if kind == "DeclareLaunchArgument"}
    assert arguments["hardware"]["choices"] == list(PLUGINS) and "use_sim_time" in arguments
    executables = {(k["package"], k["executable"]) for kind, _, k in calls if kind == "Node"}
    assert {("mujoco_ros2_control", "mujoco_ros2_control"), ("controller_manager", "ros2_control_node")} <= executables
    for constant in ("URDF_XACRO", "CONTROLLERS", "MUJOCO_SCENE"):
        assert (share / getattr(module, constant)).is_file(), constant
    assert module.PACKAGE == variant
    module, calls = _launch(variant, "svhdesc.launch.py", monkeypatch)
    command = next(k["cmd"] for kind, _, k in calls if kind == "ExecuteProcess")
    assert command[1:4] == ["sim", variant, "--ros2"]
    module, calls = _launch(variant, "moveit.launch.py", monkeypatch)
    for constant in ("URDF_XACRO", "SRDF", "KINEMATICS", "JOINT_LIMITS", "MOVEIT_CONTROLLERS"):
        assert (share / getattr(module, constant)).is_file(), constant
    assert ("moveit_ros_move_group", "move_group") in {
        (k["package"], k["executable"]) for kind, _, k in calls if kind == "Node"
    }
    # Seeded fault: a file that imports a name the launch API does not have is refused.
    with pytest.raises(AssertionError, match="launch.actions"):
        for node in ast.walk(ast.parse("from launch.actions import Spawner\n")):
            if isinstance(node, ast.ImportFrom):
                assert {a.name for a in node.names} <= LAUNCH_API[node.module], node.module
