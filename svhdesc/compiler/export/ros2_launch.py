"""IR -> the ROS 2 package's launch files (``ros2 launch <variant> <file>``).

Each file is a fixed body (below) after a block of constants, the variant's names and paths written with
``repr`` (deterministic). Paths are relative to the package's share directory, which is the variant folder.
"""

from __future__ import annotations

import json

from svhdesc.compiler.export.package import package_name
from svhdesc.compiler.export.ros2 import FOLDER, controllers, forward_controllers, velocity_controllers
from svhdesc.compiler.export.ros2_control import (
    CONTROLLERS_FILE,
    DEFAULT_HARDWARE,
    MUJOCO_FOLDER,
    PLUGINS,
    urdf_xacro_file,
)
from svhdesc.compiler.export.yamlfmt import GENERATED
from svhdesc.ir import Robot
from svhdesc.model import ROS2_JOINT_STATE_BROADCASTER

_SUBSTITUTIONS = """\
from launch.substitutions import (
    Command,
{extra}    FindExecutable,
    LaunchConfiguration,
    PathJoinSubstitution,
{more})
"""

_SIM_IMPORTS = (
    """\
from launch import LaunchDescription
from launch.actions import DeclareLaunchArgument, IncludeLaunchDescription
from launch.conditions import LaunchConfigurationEquals
from launch.launch_description_sources import PythonLaunchDescriptionSource
"""
    + _SUBSTITUTIONS.format(extra="", more="    PythonExpression,\n")
    + """\
from launch_ros.actions import Node
from launch_ros.parameter_descriptions import ParameterValue
from launch_ros.substitutions import FindPackageShare
"""
)

_SVHDESC_IMPORTS = (
    """\
from launch import LaunchDescription
from launch.actions import DeclareLaunchArgument, ExecuteProcess
"""
    + _SUBSTITUTIONS.format(extra="    EnvironmentVariable,\n", more="")
    + """\
from launch_ros.actions import Node
from launch_ros.parameter_descriptions import ParameterValue
from launch_ros.substitutions import FindPackageShare
"""
)

_MOVEIT_IMPORTS = """\
from launch import LaunchDescription
from launch.actions import DeclareLaunchArgument
from launch.substitutions import LaunchConfiguration
from launch_ros.actions import Node
from moveit_configs_utils import MoveItConfigsBuilder
"""

_DESCRIPTION = """

def robot_description(share, hardware):
    \"\"\"The URDF, xacro-expanded with the ros2_control hardware chosen.\"\"\"
    xacro = PathJoinSubstitution([FindExecutable(name="xacro")])
    command = [xacro, " ", PathJoinSubstitution([share, URDF_XACRO]), " hardware:=", hardware]
    command += [" controllers:=", PathJoinSubstitution([share, CONTROLLERS])]
    return {"robot_description": ParameterValue(Command(command), value_type=str)}
"""

_SIM = """

def generate_launch_description():
    hardware = LaunchConfiguration("hardware")
    share = FindPackageShare(PACKAGE)
    controllers = PathJoinSubstitution([share, CONTROLLERS])
    description = robot_description(share, hardware)
    sim_time = {"use_sim_time": LaunchConfiguration("use_sim_time")}
    actions = [
        DeclareLaunchArgument(
            "hardware",
            default_value=DEFAULT_HARDWARE,
            choices=HARDWARE,
            description="ros2_control hardware: MuJoCo, Gazebo (gz) or mock components",
        ),
        DeclareLaunchArgument(
            "use_sim_time",
            description="the simulator's /clock (mock: wall time)",
            default_value=PythonExpression(["'false' if '", hardware, "' == 'mock' else 'true'"]),
        ),
        Node(
            package="robot_state_publisher",
            executable="robot_state_publisher",
            output="screen",
            parameters=[description, sim_time],
        ),
        Node(
            package="mujoco_ros2_control",
            executable="mujoco_ros2_control",
            output="screen",
            parameters=[
                description,
                controllers,
                sim_time,
                {"mujoco_model_path": PathJoinSubstitution([share, MUJOCO_SCENE])},
            ],
            condition=LaunchConfigurationEquals("hardware", "mujoco"),
        ),
        Node(
            package="controller_manager",
            executable="ros2_control_node",
            output="screen",
            parameters=[controllers, sim_time],
            condition=LaunchConfigurationEquals("hardware", "mock"),
        ),
        IncludeLaunchDescription(
            PythonLaunchDescriptionSource(
                PathJoinSubstitution([FindPackageShare("ros_gz_sim"), "launch", "gz_sim.launch.py"])
            ),
            launch_arguments={"gz_args": "-r empty.sdf"}.items(),
            condition=LaunchConfigurationEquals("hardware", "gazebo"),
        ),
        Node(
            package="ros_gz_sim",
            executable="create",
            output="screen",
            arguments=["-topic", "robot_description", "-name", PACKAGE],
            condition=LaunchConfigurationEquals("hardware", "gazebo"),
        ),
        Node(
            package="ros_gz_bridge",
            executable="parameter_bridge",
            arguments=["/clock@rosgraph_msgs/msg/Clock[gz.msgs.Clock"],
            condition=LaunchConfigurationEquals("hardware", "gazebo"),
        ),
    ]
    for controller in SPAWN + INACTIVE:
        actions.append(
            Node(
                package="controller_manager",
                executable="spawner",
                output="screen",
                arguments=[controller, "--controller-manager", "/controller_manager", "--param-file", controllers]
                + (["--inactive"] if controller in INACTIVE else []),
                parameters=[sim_time],
            )
        )
    return LaunchDescription(actions)
"""

_SVHDESC = """

def generate_launch_description():
    share = FindPackageShare(PACKAGE)
    pace = LaunchConfiguration("pace")
    svhdesc = EnvironmentVariable("SVHDESC", default_value="svhdesc")
    return LaunchDescription(
        [
            DeclareLaunchArgument("keyframe", default_value="home", description="start pose (a keyframe of the model)"),
            DeclareLaunchArgument("pace", default_value="realtime", choices=["realtime", "as-fast"]),
            ExecuteProcess(
                cmd=[svhdesc, "sim", PACKAGE, "--ros2", "--keyframe", LaunchConfiguration("keyframe"), ["--", pace]],
                output="screen",
            ),
            Node(
                package="robot_state_publisher",
                executable="robot_state_publisher",
                output="screen",
                parameters=[robot_description(share, "mock"), {"use_sim_time": True}],
            ),
        ]
    )
"""

_MOVEIT = """

def generate_launch_description():
    config = (
        MoveItConfigsBuilder(PACKAGE, package_name=PACKAGE)
        .robot_description(file_path=URDF_XACRO, mappings={"hardware": "mock"})
        .robot_description_semantic(file_path=SRDF)
        .robot_description_kinematics(file_path=KINEMATICS)
        .joint_limits(file_path=JOINT_LIMITS)
        .trajectory_execution(file_path=MOVEIT_CONTROLLERS)
        .planning_pipelines(pipelines=["ompl"])
        .to_moveit_configs()
    )
    return LaunchDescription(
        [
            DeclareLaunchArgument("use_sim_time", default_value="true"),
            Node(
                package="moveit_ros_move_group",
                executable="move_group",
                output="screen",
                parameters=[config.to_dict(), {"use_sim_time": LaunchConfiguration("use_sim_time")}],
            ),
        ]
    )
"""


def _constants(robot: Robot, extra: dict[str, object]) -> str:
    """The variant's names and paths, as double-quoted literals (JSON's strings and lists are Python's)."""
    values: dict[str, object] = {
        "PACKAGE": package_name(robot),
        "URDF_XACRO": f"{FOLDER}/urdf/{urdf_xacro_file(robot)}",
    }
    values.update(extra)
    return "".join(f"{name} = {json.dumps(value)}\n" for name, value in values.items())


def _render(robot: Robot, doc: str, imports: str, body: str, extra: dict[str, object]) -> bytes:
    header = f"# {GENERATED}\n" + f'"""{doc}"""\n\n'
    return (header + imports + "\n" + _constants(robot, extra) + body).encode()


def export_sim_launch(robot: Robot) -> bytes:
    inactive = [name for name, _ in forward_controllers(robot)]  # loaded inactive, as ur_robot_driver's launch does
    spawn = [ROS2_JOINT_STATE_BROADCASTER] + [name for name, _, _ in controllers(robot)]
    spawn += [name for name, _ in velocity_controllers(robot)]  # active: nothing else drives those joints
    extra = {
        "CONTROLLERS": CONTROLLERS_FILE,
        "MUJOCO_SCENE": f"{MUJOCO_FOLDER}/scene.xml",
        "HARDWARE": list(PLUGINS),
        "DEFAULT_HARDWARE": DEFAULT_HARDWARE,
        "SPAWN": spawn,
        "INACTIVE": inactive,
    }
    doc = f"ros2 launch {robot.name} sim.launch.py hardware:={'|'.join(PLUGINS)}: ros2_control and the controllers."
    return _render(robot, doc, _SIM_IMPORTS, _DESCRIPTION + _SIM, extra)


def export_svhdesc_launch(robot: Robot) -> bytes:
    doc = f"ros2 launch {robot.name} svhdesc.launch.py: svhdesc's own simulation node (sim --ros2) and TF."
    return _render(robot, doc, _SVHDESC_IMPORTS, _DESCRIPTION + _SVHDESC, {"CONTROLLERS": CONTROLLERS_FILE})


def export_moveit_launch(robot: Robot) -> bytes:
    config = f"{FOLDER}/config"
    extra = {
        "SRDF": f"{config}/{robot.name}.srdf",
        "KINEMATICS": f"{config}/kinematics.yaml",
        "JOINT_LIMITS": f"{config}/joint_limits.yaml",
        "MOVEIT_CONTROLLERS": f"{config}/moveit_controllers.yaml",
    }
    doc = f"ros2 launch {robot.name} moveit.launch.py: move_group with this package's MoveIt 2 config."
    return _render(robot, doc, _MOVEIT_IMPORTS, _MOVEIT, extra)
