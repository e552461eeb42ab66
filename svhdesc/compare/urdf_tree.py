"""The URDF as sdformat's parser reads it for Gazebo: links with inertials and mesh collisions, joints,
the mimic-joint plugins, the <gazebo> mu of each link; and the link poses and fixed-joint lumps."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

MU = 1.0  # sdformat surface.sdf <friction><ode><mu> default


def origin(element: Any) -> np.ndarray:
    transform = np.eye(4)
    origin = element.find("origin") if element is not None else None
    if origin is None:
        return transform
    xyz = [float(v) for v in origin.get("xyz", "0 0 0").split()]
    roll, pitch, yaw = (float(v) for v in origin.get("rpy", "0 0 0").split())
    transform[:3, :3] = rotz(yaw) @ roty(pitch) @ rotx(roll)
    transform[:3, 3] = xyz
    return transform


def rotx(a: float) -> np.ndarray:
    c, s = math.cos(a), math.sin(a)
    return np.array([[1, 0, 0], [0, c, -s], [0, s, c]])


def roty(a: float) -> np.ndarray:
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]])


def rotz(a: float) -> np.ndarray:
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])


def axis_rotation(axis: np.ndarray, angle: float) -> np.ndarray:
    x, y, z = axis
    c, s, t = math.cos(angle), math.sin(angle), 1 - math.cos(angle)
    return np.array(
        [
            [t * x * x + c, t * x * y - s * z, t * x * z + s * y],
            [t * x * y + s * z, t * y * y + c, t * y * z - s * x],
            [t * x * z - s * y, t * y * z + s * x, t * z * z + c],
        ]
    )


@dataclass
class Link:
    name: str
    mass: float = 0.0
    com: np.ndarray = field(default_factory=lambda: np.zeros(3))  # in the link frame
    inertia: np.ndarray = field(default_factory=lambda: np.zeros((3, 3)))  # about the com, link axes
    meshes: list[tuple[Path, np.ndarray]] = field(default_factory=list)  # collision OBJ, link-frame pose
    mu: float = MU


@dataclass
class Joint:
    name: str
    kind: str
    parent: str
    child: str
    origin: np.ndarray
    axis: np.ndarray
    lower: float
    upper: float
    effort: float
    damping: float
    velocity: float = math.inf  # rad/s, the URDF's limit (joint_limits_interface saturates commands with it)


@dataclass
class Mimic:
    follower: str
    leader: str
    multiplier: float
    offset: float
    max_effort: float


def read_urdf(text: str) -> tuple[dict[str, Link], list[Joint], list[Mimic]]:
    from lxml import etree

    root = etree.fromstring(text.encode())
    links = {link.name: link for link in map(_link, root.findall("link"))}
    for gazebo in root.findall("gazebo"):
        mu = gazebo.find("mu1")
        if gazebo.get("reference") in links and mu is not None:
            links[gazebo.get("reference")].mu = float(mu.text)
    joints = [_joint(element) for element in root.findall("joint")]
    mimics = [_mimic(plugin) for plugin in root.iter("plugin") if "mimic_joint_plugin" in plugin.get("filename", "")]
    return links, joints, mimics


def _link(element: Any) -> Link:
    """A <link>: its inertial (com and inertia in link axes) and its mesh collisions."""
    link = Link(element.get("name"))
    inertial = element.find("inertial")
    if inertial is not None:
        frame = origin(inertial)
        link.mass = float(inertial.find("mass").get("value"))
        values = inertial.find("inertia")
        get = {k: float(values.get(k, "0")) for k in ("ixx", "ixy", "ixz", "iyy", "iyz", "izz")}
        local = np.array(
            [
                [get["ixx"], get["ixy"], get["ixz"]],
                [get["ixy"], get["iyy"], get["iyz"]],
                [get["ixz"], get["iyz"], get["izz"]],
            ]
        )
        link.com = frame[:3, 3].copy()
        link.inertia = frame[:3, :3] @ local @ frame[:3, :3].T
    for collision in element.findall("collision"):
        mesh = collision.find("geometry/mesh")
        if mesh is not None:
            link.meshes.append((Path(mesh.get("filename")), origin(collision)))
    return link


def _joint(element: Any) -> Joint:
    """A <joint>, with sdformat's defaults where <limit>, <dynamics> or <axis> is missing."""
    limit = element.find("limit")
    dynamics = element.find("dynamics")
    axis = element.find("axis")
    return Joint(
        element.get("name"),
        element.get("type"),
        element.find("parent").get("link"),
        element.find("child").get("link"),
        origin(element),
        np.array([float(v) for v in axis.get("xyz").split()]) if axis is not None else np.array([1.0, 0, 0]),
        float(limit.get("lower", "0")) if limit is not None else -math.inf,
        float(limit.get("upper", "0")) if limit is not None else math.inf,
        float(limit.get("effort", "inf")) if limit is not None else math.inf,
        float(dynamics.get("damping", "0")) if dynamics is not None else 0.0,
        float(limit.get("velocity", "inf")) if limit is not None else math.inf,
    )


def _mimic(plugin: Any) -> Mimic:
    """A mimic_joint_plugin's follower, leader and gains (its PID mode is refused: not modelled)."""

    def text(tag: str, default: str) -> str:
        node = plugin.find(tag)
        return node.text if node is not None else default

    if plugin.find("hasPID") is not None:
        raise ValueError(f"mimic plugin {plugin.get('name')} has hasPID: its PID mode is not modelled")
    return Mimic(
        text("mimicJoint", ""),
        text("joint", ""),
        float(text("multiplier", "1")),
        float(text("offset", "0")),
        float(text("maxEffort", "nan")),
    )


def load_obj(path: Path) -> tuple[np.ndarray, np.ndarray]:
    """Vertices and triangles of a Wavefront OBJ hull (v and f records; polygons fanned into triangles)."""
    vertices: list[list[float]] = []
    faces: list[list[int]] = []
    for line in path.read_text().splitlines():
        fields = line.split()
        if not fields:
            continue
        if fields[0] == "v":
            vertices.append([float(v) for v in fields[1:4]])
        elif fields[0] == "f":
            corners = [int(f.split("/")[0]) for f in fields[1:]]
            corners = [c - 1 if c > 0 else len(vertices) + c for c in corners]
            faces += [[corners[0], corners[i], corners[i + 1]] for i in range(1, len(corners) - 1)]
    if not vertices or not faces:
        raise ValueError(f"{path}: no triangles")
    return np.ascontiguousarray(vertices, dtype=np.float64), np.ascontiguousarray(faces, dtype=np.int32)


def tree(
    links: dict[str, Link], joints: list[Joint], home: dict[str, float]
) -> tuple[dict[str, np.ndarray], dict[str, str], list[Joint], str]:
    """Link poses at ``home`` (world frame), the lump each link belongs to (fixed joints merge a link into its
    parent's, as sdformat's URDF parser does), the joints parents first, and the root link."""
    children: dict[str, list[Joint]] = {}
    for joint in joints:
        children.setdefault(joint.parent, []).append(joint)
    roots = set(links) - {j.child for j in joints}
    if len(roots) != 1:
        raise ValueError(f"the URDF has {len(roots)} root links")
    root = roots.pop()
    pose, lump = {root: np.eye(4)}, {root: root}
    order: list[Joint] = []
    stack = [root]
    while stack:
        parent = stack.pop()
        for joint in children.get(parent, []):
            motion = np.eye(4)
            if joint.kind in ("revolute", "continuous"):
                motion[:3, :3] = axis_rotation(joint.axis / np.linalg.norm(joint.axis), home.get(joint.name, 0.0))
            elif joint.kind != "fixed":
                raise ValueError(f"joint {joint.name}: type {joint.kind} is not modelled")
            pose[joint.child] = pose[parent] @ joint.origin @ motion
            lump[joint.child] = lump[parent] if joint.kind == "fixed" else joint.child
            order.append(joint)
            stack.append(joint.child)
    return pose, lump, order, root


def lumped_inertial(
    links: dict[str, Link], pose: dict[str, np.ndarray], members: list[str]
) -> tuple[float, np.ndarray, np.ndarray]:
    """Mass, world centre of mass and world inertia about it of links welded together."""
    mass = sum(links[n].mass for n in members)
    if mass <= 0:
        return 0.0, np.zeros(3), np.zeros((3, 3))
    centres = {n: pose[n][:3, :3] @ links[n].com + pose[n][:3, 3] for n in members}
    com = sum(links[n].mass * centres[n] for n in members) / mass
    inertia = np.zeros((3, 3))
    for n in members:
        rotation, offset = pose[n][:3, :3], centres[n] - com
        inertia += rotation @ links[n].inertia @ rotation.T
        inertia += links[n].mass * (offset @ offset * np.eye(3) - np.outer(offset, offset))
    return mass, com, inertia
