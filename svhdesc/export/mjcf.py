"""IR -> MJCF following MuJoCo Menagerie conventions, plus scene.xml."""

from __future__ import annotations

from typing import Any

from lxml import etree

from ..ir import Geometry, Joint, Link, Robot
from ..stages.frames import quat_wxyz
from .xmlfmt import num, nums, serialise, sub

JOINT_TYPES = {"revolute": "hinge", "continuous": "hinge", "prismatic": "slide"}


def _pose_attrs(pose: Any) -> dict[str, str]:
    attrs = {}
    if any(pose.xyz):
        attrs["pos"] = nums(pose.xyz)
    if any(pose.rpy):
        attrs["quat"] = nums(quat_wxyz(pose))
    return attrs


def _geom(body: etree._Element, geometry: Geometry, cls: str, link: Link) -> None:
    attrs = {"class": cls, **_pose_attrs(geometry.origin)}
    if geometry.kind == "mesh":
        attrs.update(type="mesh", mesh=geometry.mesh.removesuffix(".stl"))  # type: ignore[union-attr]
    elif geometry.kind == "box":
        attrs.update(type="box", size=nums(s / 2.0 for s in geometry.size))
    elif geometry.kind == "cylinder":
        attrs.update(type="cylinder", size=nums((geometry.size[0], geometry.size[1] / 2.0)))
    elif geometry.kind == "capsule":
        attrs.update(type="capsule", size=nums((geometry.size[0], geometry.size[1] / 2.0)))
    elif geometry.kind == "sphere":
        attrs.update(type="sphere", size=num(geometry.size[0]))
    if cls == "visual" and geometry.rgba is not None:
        attrs["rgba"] = nums(geometry.rgba)
    if cls == "collision" and link.contact is not None:
        contact = link.contact
        attrs["condim"] = str(contact.condim)
        attrs["friction"] = nums((contact.mu, contact.torsional or 0.005, contact.rolling or 0.0001))
    sub(body, "geom", **attrs)


def _joint(body: etree._Element, joint: Joint) -> None:
    attrs = {"name": joint.name, "type": JOINT_TYPES[joint.type], "axis": nums(joint.axis)}
    if joint.type != "continuous":
        attrs["range"] = nums((joint.lower, joint.upper))
    if joint.damping:
        attrs["damping"] = num(joint.damping)
    if joint.armature:
        attrs["armature"] = num(joint.armature)
    if joint.friction:
        attrs["frictionloss"] = num(joint.friction)
    sub(body, "joint", **attrs)


def _body(parent: etree._Element, robot: Robot, link: Link, joint: Joint | None) -> None:
    attrs = {"name": link.name}
    if joint is not None:
        attrs.update(_pose_attrs(joint.origin))
    body = sub(parent, "body", **attrs)
    if link.inertial is not None:
        inertial = link.inertial
        ixx, ixy, ixz, iyy, iyz, izz = inertial.inertia
        sub(body, "inertial", pos=nums(inertial.com), mass=num(inertial.mass),
            fullinertia=nums((ixx, iyy, izz, ixy, ixz, iyz)))
    if joint is not None and joint.movable:
        _joint(body, joint)
    for geometry in link.visuals:
        _geom(body, geometry, "visual", link)
    for geometry in link.collisions:
        _geom(body, geometry, "collision", link)
    for sensor in robot.sensors:
        if sensor.link == link.name:
            sub(body, "site", name=sensor.name, pos=nums(sensor.site_pos), size=num(sensor.site_size),
                type="sphere", rgba="1 0.3 0.3 0.3", group="4")
    for child_joint in robot.child_joints(link.name):
        _body(body, robot, robot.link(child_joint.child), child_joint)


def mjcf_joint_order(robot: Robot) -> list[str]:
    """Movable joints in MuJoCo's qpos order (depth-first over the kinematic tree)."""
    order: list[str] = []

    def visit(link: str) -> None:
        for joint in robot.child_joints(link):
            if joint.movable:
                order.append(joint.name)
            visit(joint.child)

    visit(robot.root)
    return order


def _excludes(robot: Robot) -> list[tuple[str, str]]:
    """Pairs of collision bodies at most two steps apart in the tree of collision bodies.

    Geometry-less bodies are looked through. Two steps (grandparent, sibling) because a finger's
    proximal phalanx rests against the palm across its knuckle body, and neighbouring knuckles touch.
    """
    parent_of = {j.child: j.parent for j in robot.joints}
    colliding = [link.name for link in robot.links if link.collisions]

    def collision_parent(name: str) -> str | None:
        ancestor = parent_of.get(name)
        while ancestor is not None and ancestor not in colliding:
            ancestor = parent_of.get(ancestor)
        return ancestor

    up = {name: collision_parent(name) for name in colliding}
    pairs = set()
    for name in colliding:
        parent = up[name]
        if parent is None:
            continue
        pairs.add((parent, name))
        if up[parent] is not None:
            pairs.add((up[parent], name))
        for sibling in colliding:
            if sibling != name and up[sibling] == parent and (sibling, name) not in pairs:
                pairs.add((name, sibling))
    order = {name: i for i, name in enumerate(colliding)}
    return sorted(pairs, key=lambda pair: (order[pair[0]], order[pair[1]]))


def export_mjcf(robot: Robot, settings: dict[str, Any]) -> bytes:
    sim = settings["simulation"]
    root = etree.Element("mujoco", model=robot.name)
    root.append(etree.Comment(" Generated by svhdesc from one source; edit the sources, not this file. "))
    sub(root, "compiler", angle="radian", meshdir="assets", autolimits="true")
    sub(root, "option", timestep=num(sim.get("timestep", 0.002)), integrator="implicitfast", cone="elliptic",
        impratio="10")
    default = sub(root, "default")
    classes = sub(default, "default", class_=robot.name)
    sub(sub(classes, "default", class_="visual"), "geom", type="mesh", contype="0", conaffinity="0", group="2",
        density="0")
    sub(sub(classes, "default", class_="collision"), "geom", group="3", density="0", solref="0.002 1",
        solimp="0.95 0.99 0.001")
    asset = sub(root, "asset")
    meshes = sorted({g.mesh for link in robot.links for g in (*link.visuals, *link.collisions) if g.kind == "mesh"})
    for mesh in meshes:
        sub(asset, "mesh", name=mesh.removesuffix(".stl"), file=mesh)  # type: ignore[union-attr]
    worldbody = sub(root, "worldbody")
    top = sub(worldbody, "body", name=f"{robot.name}_root", childclass=robot.name)
    # Geometry-less roots (a URDF 'world' link) become the world itself.
    root_link = robot.link(robot.root)
    if root_link.has_geometry or root_link.inertial is not None:
        _body(top, robot, root_link, None)
    else:
        for joint in robot.child_joints(robot.root):
            _body(top, robot, robot.link(joint.child), joint)
    contact = sub(root, "contact")
    for body1, body2 in _excludes(robot):
        sub(contact, "exclude", body1=body1, body2=body2)
    equality = sub(root, "equality")
    for joint in robot.joints:
        if joint.mimic is not None:
            coeffs = list(joint.mimic.coeffs) + [0.0] * (5 - len(joint.mimic.coeffs))
            sub(equality, "joint", name=f"{joint.name}_coupling", joint1=joint.name, joint2=joint.mimic.joint,
                polycoef=nums(coeffs), solref=nums(sim["coupling_solref"]), solimp=nums(sim["coupling_solimp"]))
    actuator = sub(root, "actuator")
    for act in robot.actuators:
        sub(actuator, "position", name=act.name, joint=act.joint, kp=num(act.kp), dampratio=num(act.dampratio),
            ctrlrange=nums((act.lower, act.upper)), forcerange=nums((-act.effort, act.effort)))
    sensors = sub(root, "sensor")
    for sensor in robot.sensors:
        sub(sensors, "touch", name=sensor.name, site=sensor.name)
    order = mjcf_joint_order(robot)
    keyframe = sub(root, "keyframe")
    for frame in robot.keyframes:
        values = dict(frame.qpos)
        sub(keyframe, "key", name=frame.name, qpos=nums(values[j] for j in order),
            ctrl=nums(min(max(values[a.joint], a.lower), a.upper) for a in robot.actuators))
    for element in (contact, equality, actuator, sensors, keyframe):
        if len(element) == 0:
            root.remove(element)
    return serialise(root)


def export_scene(robot: Robot, model_file: str, floor_z: float) -> bytes:
    root = etree.Element("mujoco", model=f"{robot.name} scene")
    sub(root, "include", file=model_file)
    sub(root, "statistic", center="0 0 0.3" if floor_z == 0 else "0 0 0.1", extent="1" if floor_z == 0 else "0.3")
    visual = sub(root, "visual")
    sub(visual, "headlight", diffuse="0.6 0.6 0.6", ambient="0.3 0.3 0.3", specular="0 0 0")
    sub(visual, "rgba", haze="0.15 0.25 0.35 1")
    sub(visual, "global", azimuth="120", elevation="-20")
    asset = sub(root, "asset")
    sub(asset, "texture", type="skybox", builtin="gradient", rgb1="0.3 0.5 0.7", rgb2="0 0 0", width="512",
        height="3072")
    sub(asset, "texture", type="2d", name="groundplane", builtin="checker", mark="edge", rgb1="0.2 0.3 0.4",
        rgb2="0.1 0.2 0.3", markrgb="0.8 0.8 0.8", width="300", height="300")
    sub(asset, "material", name="groundplane", texture="groundplane", texuniform="true", texrepeat="5 5",
        reflectance="0.2")
    worldbody = sub(root, "worldbody")
    sub(worldbody, "light", pos="0 0 1.5", dir="0 0 -1", directional="true")
    sub(worldbody, "geom", name="floor", pos=nums((0, 0, floor_z)), size="0 0 0.05", type="plane",
        material="groundplane")
    return serialise(root)
