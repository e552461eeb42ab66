"""IR -> the ROS 1 side of a variant: the thesis' connector file, the node's launcher and its launch file."""

from __future__ import annotations

from collections.abc import Mapping

from lxml import etree

from svhdesc.compiler.export.xmlfmt import serialise, sub
from svhdesc.compiler.export.yamlfmt import GENERATED, dump_yaml
from svhdesc.ir import Robot
from svhdesc.model import NODE_NAME, NODE_SCRIPT, connector_topics


def export_connector(robot: Robot, d_gains: Mapping[str, float]) -> bytes:
    """One connector entry per actuated joint (thesis sec. 4.2.3); gains are the MJCF servo's,
    ``d_gains`` the damping MuJoCo derives from each servo's dampratio."""
    joints = []
    for actuator in (a for a in robot.actuators if not a.velocity):  # a velocity servo takes no position target
        entry = {"name": actuator.joint, "p_gain": float(actuator.kp), "d_gain": float(d_gains[actuator.name])}
        entry.update(connector_topics(actuator.joint))
        joints.append(entry)
    return dump_yaml({"joints": joints})


def export_node_script(robot: Robot) -> bytes:
    """The executable roslaunch starts: svhdesc from PATH (or $SVHDESC) serving this variant."""
    return (
        "#!/bin/sh\n"
        f"# {GENERATED}\n"
        f"# roslaunch starts this: the svhdesc simulation of {robot.name} as a ROS node.\n"
        f'exec "${{SVHDESC:-svhdesc}}" sim {robot.name} --ros "$@"\n'
    ).encode()


def export_launch(robot: Robot, urdf_name: str) -> bytes:
    """``roslaunch <variant> sim.launch``: robot_description, the simulation node, robot_state_publisher."""
    root = etree.Element("launch")
    root.append(etree.Comment(f" {GENERATED} "))
    args = (
        ("keyframe", "home", "start pose (a keyframe of the model)"),
        ("pace", "realtime", "realtime | as-fast"),
        ("rate", "50", "/joint_states rate in Hz"),
    )
    for name, default, doc in args:
        sub(root, "arg", name=name, default=default, doc=doc)
    sub(root, "param", name="/use_sim_time", value="true")
    sub(root, "param", name="robot_description", textfile=f"$(find {robot.name})/{urdf_name}")
    sub(
        root,
        "node",
        name=NODE_NAME,
        pkg=robot.name,
        type=NODE_SCRIPT,
        output="screen",
        required="true",
        args="--keyframe $(arg keyframe) --$(arg pace) --rate $(arg rate)",
    )
    sub(root, "node", name="robot_state_publisher", pkg="robot_state_publisher", type="robot_state_publisher")
    return serialise(root)
