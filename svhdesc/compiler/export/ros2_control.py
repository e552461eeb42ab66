"""IR -> the ROS 2 robot description: the URDF as a xacro file with a ``<ros2_control>`` system whose hardware
plugin a xacro argument selects (``hardware:=mujoco|gazebo|mock``), and the MJCF mujoco_ros2_control loads.

Takes the ROS 2 robot (``svhdesc.compiler.export.ros2.ros2_robot``): its joint names are the ROS 2 drivers'.
Mimic joints follow ros2_control Jazzy: the coupling lives in the URDF's ``<mimic>``; the ``<ros2_control>`` joint
is marked ``mimic="true"`` and has state interfaces only (hardware_interface's component_parser refuses command
interfaces on an active mimic joint).
"""

from __future__ import annotations

from lxml import etree

from svhdesc.compiler.export.mjcf import export_mjcf, export_scene
from svhdesc.compiler.export.package import package_name
from svhdesc.compiler.export.ros2 import COMMAND_INTERFACES, FOLDER, STATE_INTERFACES
from svhdesc.compiler.export.urdf import export_urdf
from svhdesc.compiler.export.xmlfmt import num, serialise, sub
from svhdesc.compiler.export.yamlfmt import GENERATED
from svhdesc.ir import Robot

XACRO = "http://www.ros.org/wiki/xacro"
X = f"{{{XACRO}}}"
# hardware:= value -> the ros2_control hardware plugin.
PLUGINS = {
    "mujoco": "mujoco_ros2_control/MujocoSystem",  # moveit/mujoco_ros2_control
    "gazebo": "gz_ros2_control/GazeboSimSystem",  # gz_ros2_control (Gazebo Harmonic on Jazzy)
    "mock": "mock_components/GenericSystem",  # ros2_control's dry-run hardware
}
DEFAULT_HARDWARE = "mujoco"
MACRO = "svhdesc_ros2_control"
MUJOCO_FOLDER = f"{FOLDER}/mujoco"  # the ROS 2 MJCF: its joints renamed, its meshes the variant's assets/
CONTROLLERS_FILE = f"{FOLDER}/config/ros2_controllers.yaml"


def ros2_control_file(robot: Robot) -> str:
    return f"{robot.name}.ros2_control.xacro"


def urdf_xacro_file(robot: Robot) -> str:
    return f"{robot.name}.urdf.xacro"


def _home(robot: Robot) -> dict[str, float]:
    frames = {k.name: dict(k.qpos) for k in robot.keyframes}
    return frames.get("home") or next(iter(frames.values()), {})


def _interfaces(joint: etree._Element, initial: float | None, command: tuple[str, ...]) -> None:
    for name in command:
        sub(joint, "command_interface", name=name)
    for name in STATE_INTERFACES:
        state = sub(joint, "state_interface", name=name)
        if name == "position" and initial is not None:
            sub(state, "param", name="initial_value").text = num(initial)


def export_ros2_control(robot: Robot) -> bytes:
    """The ``svhdesc_ros2_control`` macro: one system with every actuated joint (command: position; velocity on a
    velocity servo) and every mimic joint (state only), its plugin chosen by ``hardware``; for Gazebo, also
    gz_ros2_control's plugin."""
    root = etree.Element("robot", nsmap={"xacro": XACRO})
    root.append(etree.Comment(f" {GENERATED} "))
    macro = sub(root, f"{X}macro", name=MACRO, params="name hardware controllers")
    known = sub(macro, f"{X}unless", value=f"${{hardware in {sorted(PLUGINS)!r}}}")
    sub(known, f"{X}if", value=f"${{xacro.fatal('hardware must be one of {', '.join(sorted(PLUGINS))}')}}")
    system = sub(macro, "ros2_control", name="${name}", type="system")
    hardware = sub(system, "hardware")
    for value, plugin in PLUGINS.items():
        sub(sub(hardware, f"{X}if", value=f"${{hardware == '{value}'}}"), "plugin").text = plugin
    home = _home(robot)
    for actuator in robot.actuators:
        joint = sub(system, "joint", name=actuator.joint)
        _interfaces(joint, home.get(actuator.joint), ("velocity",) if actuator.velocity else COMMAND_INTERFACES)
    for mimic in (j for j in robot.joints if j.mimic):
        _interfaces(sub(system, "joint", name=mimic.name, mimic="true"), None, ())
    gazebo = sub(sub(macro, f"{X}if", value="${hardware == 'gazebo'}"), "gazebo")
    plugin = sub(
        gazebo, "plugin", filename="gz_ros2_control-system", name="gz_ros2_control::GazeboSimROS2ControlPlugin"
    )
    sub(plugin, "parameters").text = "${controllers}"
    return serialise(root)


def export_urdf_xacro(robot: Robot) -> bytes:
    """The ROS 2 URDF: the ROS 1 exporter's links and joints (ROS 2 names), without its ROS 1 transmissions and
    Gazebo classic plugins, plus the ros2_control system. ``xacro <this> hardware:=mock`` gives the URDF."""
    urdf = etree.fromstring(export_urdf(robot, f"package://{package_name(robot)}/assets"))
    root = etree.Element("robot", name=urdf.get("name"), nsmap={"xacro": XACRO})
    root.append(etree.Comment(f" {GENERATED} "))
    root.append(etree.Comment(f" hardware:= {' | '.join(PLUGINS)} "))
    sub(root, f"{X}arg", name="hardware", default=DEFAULT_HARDWARE)
    controllers = f"$(find {package_name(robot)})/{CONTROLLERS_FILE}"
    sub(root, f"{X}arg", name="controllers", default=controllers)
    sub(root, f"{X}include", filename=ros2_control_file(robot))
    sub(root, f"{X}{MACRO}", name=robot.name, hardware="$(arg hardware)", controllers="$(arg controllers)")
    for element in urdf:
        ros1 = element.tag == "transmission" or (element.tag == "gazebo" and element.find("plugin") is not None)
        if isinstance(element.tag, str) and not ros1:
            root.append(element)
    return serialise(root)


def export_mujoco_model(robot: Robot) -> bytes:
    """The MJCF with the ROS 2 joint names (mujoco_ros2_control matches joints by name), meshes from ../../assets."""
    model = etree.fromstring(export_mjcf(robot))
    model.find("compiler").set("meshdir", "../../assets")
    return serialise(model)


def export_mujoco_scene(robot: Robot) -> bytes:
    return export_scene(robot, f"{robot.name}.xml")
