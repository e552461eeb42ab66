"""IR -> MJCF following MuJoCo Menagerie conventions, plus scene.xml."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from lxml import etree

from svhdesc.compiler.export.xmlfmt import num, nums, serialise, sub
from svhdesc.core.frames import quat_wxyz
from svhdesc.ir import Actuator, Geometry, Joint, Link, Robot

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
        attrs.update(type="mesh", mesh=_mesh_name(geometry.mesh))  # type: ignore[arg-type]
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


# Joint and actuator attributes a default class may carry: what members of one role share.
JOINT_SHARED = ("damping", "armature", "frictionloss", "margin", "solreflimit", "actuatorgravcomp")
ACTUATOR_SHARED = ("kp", "dampratio")


def _joint_attrs(joint: Joint, gravcomp: bool) -> dict[str, str]:
    attrs = {"name": joint.name, "type": JOINT_TYPES[joint.type], "axis": nums(joint.axis)}
    if joint.type != "continuous":
        attrs["range"] = nums((joint.lower, joint.upper))
    if joint.damping:
        attrs["damping"] = num(joint.damping)
    if joint.armature:
        attrs["armature"] = num(joint.armature)
    if joint.friction:
        attrs["frictionloss"] = num(joint.friction)
    if joint.limit_margin:
        attrs["margin"] = num(joint.limit_margin)
    if joint.limit_solref:
        attrs["solreflimit"] = nums(joint.limit_solref)
    if gravcomp and joint.effort > 0:
        # The motor carries the weight: gravity compensation counts against the joint's effort limit,
        # together with the servo's own force.
        attrs["actuatorgravcomp"] = "true"
        attrs["actuatorfrcrange"] = nums((-joint.effort, joint.effort))
    return attrs


def _actuator_attrs(act: Actuator) -> dict[str, str]:
    limits = {"ctrlrange": nums((act.lower, act.upper))} if act.limited else {"ctrllimited": "false"}
    return {
        "name": act.name,
        "joint": act.joint,
        "kp": num(act.kp),
        "dampratio": num(act.dampratio),
        **limits,
        "forcerange": nums((-act.effort, act.effort)),
    }


@dataclass(frozen=True)
class DefaultClass:
    """A Menagerie-style default class: what its members share, written once (edit a gain in one place)."""

    name: str
    tag: str  # joint | position
    shared: dict[str, str]


def _shared(members: list[dict[str, str]], keys: tuple[str, ...]) -> dict[str, str]:
    first = members[0]
    return {k: first[k] for k in keys if k in first and all(m.get(k) == first[k] for m in members)}


FIXED_CLASSES = ("drive", "coupled", "arm", "servo", "visual", "collision")


def top_class(robot: Robot) -> str:
    """The model's own default class: the robot's name, unless a class within has it (a robot named ``arm``)."""
    return f"{robot.name}_model" if robot.name in FIXED_CLASSES else robot.name


def _roles(robot: Robot) -> tuple[dict[str, str], dict[str, str]]:
    """Joint name -> joint class, actuator name -> actuator class.

    Joints: a hand's motor-driven joints (`drive`), the joints coupled to them (`coupled`), an arm's joints (`arm`).
    Actuators: the hand's channel servos (`servo`); arm servos grouped by equal gains, named after the first joint
    of each group (`shoulder`, `elbow`, `wrist` on the UR5).
    """
    channel_joints = {c.joint for c in robot.channels}
    joints: dict[str, str] = {}
    for joint in robot.joints:
        if not joint.movable:
            continue
        joints[joint.name] = "drive" if joint.name in channel_joints else "coupled" if joint.mimic else "arm"
    actuators: dict[str, str] = {}
    groups: dict[tuple[str, str], str] = {}
    taken = {*FIXED_CLASSES, top_class(robot)}
    for act in robot.actuators:
        if act.velocity:  # a velocity servo writes its own attributes
            continue
        if act.joint in channel_joints:
            actuators[act.name] = "servo"
            continue
        gains = (num(act.kp), num(act.dampratio))
        if gains not in groups:
            stem = act.joint.split("_")[0] or "arm"
            name = stem if stem not in taken else f"{stem}_{len(groups) + 1}"
            groups[gains] = name
            taken.add(name)
        actuators[act.name] = groups[gains]
    return joints, actuators


def _default_classes(robot: Robot, gravcomp: bool) -> tuple[list[DefaultClass], dict[str, str], dict[str, str]]:
    joint_role, actuator_role = _roles(robot)
    classes = []
    for role in ("drive", "coupled", "arm"):
        members = [_joint_attrs(robot.joint(name), gravcomp) for name, r in joint_role.items() if r == role]
        if members:
            classes.append(DefaultClass(role, "joint", _shared(members, JOINT_SHARED)))
    for role in dict.fromkeys(actuator_role.values()):
        members = [_actuator_attrs(a) for a in robot.actuators if actuator_role.get(a.name) == role]
        classes.append(DefaultClass(role, "position", _shared(members, ACTUATOR_SHARED)))
    return classes, joint_role, actuator_role


def _with_class(attrs: dict[str, str], cls: DefaultClass | None) -> dict[str, str]:
    """The element's attributes less what its class already says."""
    if cls is None:
        return attrs
    own = {k: v for k, v in attrs.items() if cls.shared.get(k) != v}
    return {"class": cls.name, **own}


def _mesh_name(asset: str) -> str:
    """Asset file name without its extension (visual .stl, collision .obj; the stems differ)."""
    return asset.rsplit(".", 1)[0]


@dataclass(frozen=True)
class _Context:
    robot: Robot
    gravcomp: bool
    joint_class: dict[str, DefaultClass]  # joint name -> its class


def _body(parent: etree._Element, ctx: _Context, link: Link, joint: Joint | None) -> None:
    robot, gravcomp = ctx.robot, ctx.gravcomp
    attrs = {"name": link.name}
    if joint is not None:
        attrs.update(_pose_attrs(joint.origin))
    if gravcomp and link.inertial is not None:
        attrs["gravcomp"] = "1"
    body = sub(parent, "body", **attrs)
    if link.inertial is not None:
        inertial = link.inertial
        ixx, ixy, ixz, iyy, iyz, izz = inertial.inertia
        sub(
            body,
            "inertial",
            pos=nums(inertial.com),
            mass=num(inertial.mass),
            fullinertia=nums((ixx, iyy, izz, ixy, ixz, iyz)),
        )
    if joint is not None and joint.movable:
        sub(body, "joint", **_with_class(_joint_attrs(joint, gravcomp), ctx.joint_class.get(joint.name)))
    for geometry in link.visuals:
        _geom(body, geometry, "visual", link)
    for geometry in link.collisions:
        _geom(body, geometry, "collision", link)
    for sensor in robot.sensors:
        if sensor.link == link.name:
            sub(
                body,
                "site",
                name=sensor.name,
                pos=nums(sensor.site_pos),
                size=num(sensor.site_size),
                type="sphere",
                rgba="1 0.3 0.3 0.3",
                group="4",
            )
    for child_joint in robot.child_joints(link.name):
        _body(body, ctx, robot.link(child_joint.child), child_joint)


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


def _compiler_and_options(root: etree._Element, robot: Robot) -> None:
    physics = robot.physics
    sub(root, "compiler", angle="radian", meshdir="assets", autolimits="true")
    option = sub(
        root, "option", timestep=num(physics.timestep), integrator="implicitfast", cone=physics.cone, impratio="10"
    )
    if physics.noslip_iterations:
        option.set("noslip_iterations", str(physics.noslip_iterations))


def _defaults(root: etree._Element, robot: Robot, classes: list[DefaultClass]) -> None:
    top = sub(sub(root, "default"), "default", class_=top_class(robot))
    sub(sub(top, "default", class_="visual"), "geom", type="mesh", contype="0", conaffinity="0", group="2", density="0")
    sub(
        sub(top, "default", class_="collision"),
        "geom",
        group="3",
        density="0",
        solref="0.002 1",
        solimp="0.95 0.99 0.001",
    )
    for cls in classes:
        sub(sub(top, "default", class_=cls.name), cls.tag, **cls.shared)


def collision_meshes(robot: Robot) -> set[str]:
    """Names of the mesh assets that collision geoms use."""
    return {_mesh_name(g.mesh) for link in robot.links for g in link.collisions if g.kind == "mesh"}  # type: ignore[arg-type]


def _assets(root: etree._Element, robot: Robot) -> None:
    asset = sub(root, "asset")
    meshes = sorted({g.mesh for link in robot.links for g in (*link.visuals, *link.collisions) if g.kind == "mesh"})
    for mesh in meshes:
        sub(asset, "mesh", name=_mesh_name(mesh), file=mesh)  # type: ignore[arg-type]


def _worldbody(root: etree._Element, ctx: _Context) -> None:
    robot = ctx.robot
    top = sub(sub(root, "worldbody"), "body", name=f"{robot.name}_root", childclass=top_class(robot))
    # Geometry-less roots (a URDF 'world' link) become the world itself.
    root_link = robot.link(robot.root)
    if root_link.has_geometry or root_link.inertial is not None:
        _body(top, ctx, root_link, None)
    else:
        for joint in robot.child_joints(robot.root):
            _body(top, ctx, robot.link(joint.child), joint)


def _contact(root: etree._Element, robot: Robot) -> None:
    contact = sub(root, "contact")
    for body1, body2 in robot.excludes:
        sub(contact, "exclude", body1=body1, body2=body2)


def _equality(root: etree._Element, robot: Robot) -> None:
    equality = sub(root, "equality")
    for joint in robot.joints:
        if joint.mimic is not None:
            coeffs = list(joint.mimic.coeffs) + [0.0] * (5 - len(joint.mimic.coeffs))
            sub(
                equality,
                "joint",
                name=f"{joint.name}_coupling",
                joint1=joint.name,
                joint2=joint.mimic.joint,
                polycoef=nums(coeffs),
                solref=nums(robot.physics.coupling_solref),
                solimp=nums(robot.physics.coupling_solimp),
            )


def _actuators(root: etree._Element, robot: Robot, actuator_class: dict[str, DefaultClass]) -> None:
    actuator = sub(root, "actuator")
    for act in robot.actuators:
        if act.velocity:  # force = kv (ctrl - qvel), integrated implicitly
            attrs = {"name": act.name, "joint": act.joint, "kv": num(act.kp), "ctrlrange": nums((act.lower, act.upper))}
            sub(actuator, "velocity", **attrs, forcerange=nums((-act.effort, act.effort)))
            continue
        sub(actuator, "position", **_with_class(_actuator_attrs(act), actuator_class[act.name]))


def _sensors(root: etree._Element, robot: Robot) -> None:
    sensors = sub(root, "sensor")
    for sensor in robot.sensors:
        sub(sensors, "touch", name=sensor.name, site=sensor.name)


def _keyframes(root: etree._Element, robot: Robot) -> None:
    order = mjcf_joint_order(robot)
    keyframe = sub(root, "keyframe")
    for frame in robot.keyframes:
        values, targets = dict(frame.qpos), frame.servo_targets()  # the pose; the servos' targets (a grasp's: past it)
        sub(
            keyframe,
            "key",
            name=frame.name,
            qpos=nums(values[j] for j in order),
            ctrl=nums(_home_ctrl(a, targets[a.joint]) for a in robot.actuators),
        )


def _home_ctrl(actuator: Actuator, position: float) -> float:
    """A keyframe's servo target: its position (clamped to the servo's range), or still for a velocity servo."""
    if actuator.velocity:
        return 0.0
    return min(max(position, actuator.lower), actuator.upper) if actuator.limited else position


def export_mjcf(robot: Robot) -> bytes:
    return serialise(mjcf_tree(robot))


def mjcf_tree(robot: Robot) -> etree._Element:
    """The MJCF as an element tree (the batch exporter derives its model from it)."""
    gravcomp = robot.physics.gravity_compensation
    classes, joint_role, actuator_role = _default_classes(robot, gravcomp)
    by_name = {(c.tag, c.name): c for c in classes}
    ctx = _Context(robot, gravcomp, {j: by_name[("joint", role)] for j, role in joint_role.items()})
    root = etree.Element("mujoco", model=robot.name)
    root.append(etree.Comment(" Generated by svhdesc from one source; edit the sources, not this file. "))
    _compiler_and_options(root, robot)
    _defaults(root, robot, classes)
    _assets(root, robot)
    _worldbody(root, ctx)
    _contact(root, robot)
    _equality(root, robot)
    _actuators(root, robot, {a: by_name[("position", role)] for a, role in actuator_role.items()})
    _sensors(root, robot)
    _keyframes(root, robot)
    for element in list(root):
        if element.tag in {"contact", "equality", "actuator", "sensor", "keyframe"} and len(element) == 0:
            root.remove(element)
    return root


def export_scene(robot: Robot, model_file: str) -> bytes:
    """Menagerie-style scene: the model, a floor, light; an arm stands on a pedestal if the floor is lower."""
    return serialise(scene_tree(robot, model_file))


def scene_tree(robot: Robot, model_file: str) -> etree._Element:
    floor_z = robot.ground.floor_z
    pedestal = robot.ground.pedestal_radius
    root = etree.Element("mujoco", model=f"{robot.name} scene")
    sub(root, "include", file=model_file)
    sub(root, "statistic", center=nums((0.0, 0.0, floor_z / 2.0 + 0.1)), extent=num(max(0.4, 2.0 * abs(floor_z))))
    _scene_looks(root)
    _scene_ground(root, floor_z, pedestal)
    return root


def _scene_looks(root: etree._Element) -> None:
    """Light, haze, sky and the checkered floor's material."""
    visual = sub(root, "visual")
    sub(visual, "headlight", diffuse="0.6 0.6 0.6", ambient="0.3 0.3 0.3", specular="0 0 0")
    sub(visual, "rgba", haze="0.15 0.25 0.35 1")
    sub(visual, "global", azimuth="120", elevation="-20")
    asset = sub(root, "asset")
    sub(
        asset,
        "texture",
        type="skybox",
        builtin="gradient",
        rgb1="0.3 0.5 0.7",
        rgb2="0 0 0",
        width="512",
        height="3072",
    )
    sub(
        asset,
        "texture",
        type="2d",
        name="groundplane",
        builtin="checker",
        mark="edge",
        rgb1="0.2 0.3 0.4",
        rgb2="0.1 0.2 0.3",
        markrgb="0.8 0.8 0.8",
        width="300",
        height="300",
    )
    sub(
        asset,
        "material",
        name="groundplane",
        texture="groundplane",
        texuniform="true",
        texrepeat="5 5",
        reflectance="0.2",
    )


def _scene_ground(root: etree._Element, floor_z: float, pedestal: float) -> None:
    worldbody = sub(root, "worldbody")
    sub(worldbody, "light", pos="0 0 1.5", dir="0 0 -1", directional="true")
    if pedestal and floor_z < 0:
        sub(
            worldbody,
            "geom",
            name="pedestal",
            type="cylinder",
            size=nums((pedestal, -floor_z / 2.0)),
            pos=nums((0.0, 0.0, floor_z / 2.0)),
            rgba="0.3 0.3 0.32 1",
        )
    sub(
        worldbody,
        "geom",
        name="floor",
        pos=nums((0, 0, floor_z)),
        size="0 0 0.05",
        type="plane",
        material="groundplane",
    )
