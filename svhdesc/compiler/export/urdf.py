"""IR -> URDF for ROS and Gazebo: mimic tags, transmissions, Gazebo plugins, friction, inertials."""

from __future__ import annotations

from lxml import etree

from svhdesc.compiler.export.xmlfmt import num, nums, serialise, sub
from svhdesc.core.settings.coupling import linearise
from svhdesc.ir import Geometry, Joint, Link, Pose, Robot

MIMIC_PLUGIN = "libroboticsgroup_upatras_gazebo_mimic_joint_plugin.so"


def _origin(parent: etree._Element, pose: Pose) -> None:
    sub(parent, "origin", xyz=nums(pose.xyz), rpy=nums(pose.rpy))


def _geometry(parent: etree._Element, tag: str, geometry: Geometry, name: str, mesh_dir: str) -> None:
    element = sub(parent, tag, name=name)
    _origin(element, geometry.origin)
    shape = sub(element, "geometry")
    if geometry.kind == "mesh":
        sub(shape, "mesh", filename=f"{mesh_dir}/{geometry.mesh}")
    elif geometry.kind == "box":
        sub(shape, "box", size=nums(geometry.size))
    elif geometry.kind in {"cylinder", "capsule"}:  # URDF has no capsule; a cylinder is the closest
        sub(shape, "cylinder", radius=num(geometry.size[0]), length=num(geometry.size[1]))
    elif geometry.kind == "sphere":
        sub(shape, "sphere", radius=num(geometry.size[0]))
    if tag == "visual" and geometry.rgba is not None:
        material = sub(element, "material", name="rgba_" + "_".join(f"{c:g}" for c in geometry.rgba))
        sub(material, "color", rgba=nums(geometry.rgba))


def _link(root: etree._Element, link: Link, mesh_dir: str) -> None:
    element = sub(root, "link", name=link.name)
    if link.inertial is not None:
        inertial = sub(element, "inertial")
        _origin(inertial, Pose(link.inertial.com))
        sub(inertial, "mass", value=num(link.inertial.mass))
        keys = ("ixx", "ixy", "ixz", "iyy", "iyz", "izz")
        sub(inertial, "inertia", **{k: num(v) for k, v in zip(keys, link.inertial.inertia)})
    for i, geometry in enumerate(link.visuals):
        _geometry(element, "visual", geometry, f"{link.name}_visual_{i}", mesh_dir)
    for i, geometry in enumerate(link.collisions):
        _geometry(element, "collision", geometry, f"{link.name}_collision_{i}", mesh_dir)


def mimic_line(robot: Robot, joint: Joint) -> tuple[float, float]:
    """(offset, multiplier) the linear URDF <mimic> can carry for this joint's spec polynomial."""
    assert joint.mimic is not None
    channel = next(c for c in robot.channels if c.joint == joint.mimic.joint)
    return linearise(joint.mimic.coeffs, channel.lower, channel.upper)


def _joint(root: etree._Element, robot: Robot, joint: Joint) -> None:
    element = sub(root, "joint", name=joint.name, type=joint.type)
    _origin(element, joint.origin)
    sub(element, "parent", link=joint.parent)
    sub(element, "child", link=joint.child)
    if joint.movable:
        sub(element, "axis", xyz=nums(joint.axis))
        limit = {"effort": num(joint.effort), "velocity": num(joint.velocity)}
        if joint.type != "continuous":
            limit = {"lower": num(joint.lower), "upper": num(joint.upper), **limit}
        sub(element, "limit", **limit)
        sub(element, "dynamics", damping=num(joint.damping), friction=num(joint.friction))
    if joint.mimic is not None:
        offset, multiplier = mimic_line(robot, joint)
        sub(element, "mimic", joint=joint.mimic.joint, multiplier=num(multiplier), offset=num(offset))


def _transmissions(root: etree._Element, robot: Robot) -> None:
    for transmission in robot.transmissions:
        element = sub(root, "transmission", name=transmission.name)
        sub(element, "type").text = "transmission_interface/SimpleTransmission"
        joint = sub(element, "joint", name=transmission.joint)
        sub(joint, "hardwareInterface").text = transmission.interface
        actuator = sub(element, "actuator", name=f"{transmission.joint}_motor")
        sub(actuator, "hardwareInterface").text = transmission.interface
        sub(actuator, "mechanicalReduction").text = num(transmission.reduction)


def _gazebo(root: etree._Element, robot: Robot) -> None:
    for link in robot.links:
        if link.contact is None:
            continue
        element = sub(root, "gazebo", reference=link.name)
        sub(element, "mu1").text = num(link.contact.mu)
        sub(element, "mu2").text = num(link.contact.mu)
        if link.contact.torsional:
            # Soft finger: torsional friction on the link's (lumped) collision.
            for i in range(len(link.collisions)):
                collision = sub(element, "collision", name=f"{link.name}_collision_{i}")
                torsional = sub(sub(sub(collision, "surface"), "friction"), "torsional")
                sub(torsional, "coefficient").text = num(link.contact.torsional)
    control = sub(sub(root, "gazebo"), "plugin", name="gazebo_ros_control", filename="libgazebo_ros_control.so")
    sub(control, "robotNamespace").text = "/"
    for joint in robot.joints:
        if joint.mimic is None:
            continue
        offset, multiplier = mimic_line(robot, joint)
        plugin = sub(sub(root, "gazebo"), "plugin", name=f"{joint.name}_mimic", filename=MIMIC_PLUGIN)
        sub(plugin, "joint").text = joint.mimic.joint
        sub(plugin, "mimicJoint").text = joint.name
        sub(plugin, "multiplier").text = num(multiplier)
        sub(plugin, "offset").text = num(offset)
        sub(plugin, "maxEffort").text = num(joint.effort)
    for sensor in robot.sensors:
        plugin = sub(sub(root, "gazebo"), "plugin", name=f"{sensor.name}_f3d", filename="libgazebo_ros_f3d.so")
        sub(plugin, "updateRate").text = "100"
        sub(plugin, "bodyName").text = sensor.link
        sub(plugin, "topicName").text = sensor.name
        sub(plugin, "frameName").text = sensor.link


def _mujoco(root: etree._Element) -> None:
    """MuJoCo's own URDF importer cannot resolve package:// URIs: it strips each mesh's path and looks in assets/
    beside the file (where the build writes them). ROS tools (urdfdom, yourdfpy, sdformat) ignore the element."""
    sub(sub(root, "mujoco"), "compiler", meshdir="assets", strippath="true")


def export_urdf(robot: Robot, mesh_dir: str = "assets") -> bytes:
    root = etree.Element("robot", name=robot.name)
    root.append(etree.Comment(" Generated by svhdesc from one source; edit the sources, not this file. "))
    _mujoco(root)
    for link in robot.links:
        _link(root, link, mesh_dir)
    for joint in robot.joints:
        _joint(root, robot, joint)
    _transmissions(root, robot)
    _gazebo(root, robot)
    return serialise(root)
