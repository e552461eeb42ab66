"""One URDF + MJCF pair to validate: both files read once, the URDF's facts in plain numbers."""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from lxml import etree

from svhdesc.errors import SvhdescError
from svhdesc.model import Configuration, Coupling, HandId, Model, mimic_coupling


def _floats(text: str | None, default: tuple[float, ...]) -> np.ndarray:
    if text is None or not text.split():
        return np.array(default, dtype=float)
    return np.array([float(v) for v in text.split()], dtype=float)


def rpy_matrix(rpy: np.ndarray) -> np.ndarray:
    """URDF fixed-axis roll-pitch-yaw: R = Rz(yaw) Ry(pitch) Rx(roll).

    Deliberately not the builder's own (svhdesc.core.frames): a validator sharing the code it checks
    would share its bugs.
    """
    r, p, y = rpy
    cr, sr, cp, sp, cy, sy = np.cos(r), np.sin(r), np.cos(p), np.sin(p), np.cos(y), np.sin(y)
    return np.array(
        [
            [cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
            [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
            [-sp, cp * sr, cp * cr],
        ]
    )


@dataclass(frozen=True)
class UrdfJoint:
    name: str
    type: str
    parent: str
    child: str
    xyz: np.ndarray
    rpy: np.ndarray
    axis: np.ndarray
    lower: float | None
    upper: float | None
    mimic: Coupling | None  # the <mimic>: offset and multiplier of its leader

    @property
    def movable(self) -> bool:
        return self.type in {"revolute", "continuous", "prismatic"}


@dataclass(frozen=True)
class UrdfInertial:
    mass: float
    com: np.ndarray
    tensor: np.ndarray  # about the COM, in the link frame (the inertial origin's rpy applied)


@dataclass
class UrdfFacts:
    """What the checks need from a URDF, read with lxml (no parser library's interpretation)."""

    name: str
    links: dict[str, UrdfInertial | None]
    joints: dict[str, UrdfJoint]
    transmissions: dict[str, list[str]]  # transmission name -> joint names
    # Gazebo mimic plugin: coupled joint -> its coupling (offset, multiplier)
    mimic_plugins: dict[str, Coupling]
    meshes: list[str]

    @property
    def root(self) -> str:
        children = {j.child for j in self.joints.values()}
        roots = [name for name in self.links if name not in children]
        return roots[0] if roots else next(iter(self.links))


def read_urdf_facts(path: Path) -> UrdfFacts:
    root = etree.parse(str(path)).getroot()
    if root.tag != "robot":
        raise ValueError(f"root element is <{root.tag}>, not <robot>")
    links: dict[str, UrdfInertial | None] = {}
    for link in root.findall("link"):
        inertial = link.find("inertial")
        if inertial is None:
            links[link.get("name")] = None
            continue
        origin = inertial.find("origin")
        xyz = _floats(origin.get("xyz") if origin is not None else None, (0, 0, 0))
        rpy = _floats(origin.get("rpy") if origin is not None else None, (0, 0, 0))
        mass_el, inertia = inertial.find("mass"), inertial.find("inertia")
        mass = float(mass_el.get("value")) if mass_el is not None else 0.0
        keys = ("ixx", "ixy", "ixz", "iyy", "iyz", "izz")
        values = [float(inertia.get(k, 0.0)) if inertia is not None else 0.0 for k in keys]
        ixx, ixy, ixz, iyy, iyz, izz = values
        tensor = np.array([[ixx, ixy, ixz], [ixy, iyy, iyz], [ixz, iyz, izz]])
        rotation = rpy_matrix(rpy)
        links[link.get("name")] = UrdfInertial(mass, xyz, rotation @ tensor @ rotation.T)
    joints = {}
    for joint in root.findall("joint"):
        origin, axis, limit = (joint.find(t) for t in ("origin", "axis", "limit"))
        lower = upper = None
        if limit is not None and joint.get("type") != "continuous":
            lower, upper = float(limit.get("lower", 0.0)), float(limit.get("upper", 0.0))
        joints[joint.get("name")] = UrdfJoint(
            name=joint.get("name"),
            type=joint.get("type"),
            parent=joint.find("parent").get("link"),
            child=joint.find("child").get("link"),
            xyz=_floats(origin.get("xyz") if origin is not None else None, (0, 0, 0)),
            rpy=_floats(origin.get("rpy") if origin is not None else None, (0, 0, 0)),
            axis=_floats(axis.get("xyz") if axis is not None else None, (1, 0, 0)),
            lower=lower,
            upper=upper,
            mimic=mimic_coupling(joint),
        )
    transmissions = {
        t.get("name", ""): [j.get("name") for j in t.findall("joint")] for t in root.findall("transmission")
    }
    plugins = {}
    for plugin in root.iter("plugin"):
        mimic_joint, channel = plugin.findtext("mimicJoint"), plugin.findtext("joint")
        if mimic_joint and channel:
            coeffs = (float(plugin.findtext("offset") or 0.0), float(plugin.findtext("multiplier") or 1.0))
            plugins[mimic_joint.strip()] = Coupling(mimic_joint.strip(), channel.strip(), coeffs)
    meshes = [m.get("filename", "") for m in root.iter("mesh")]
    return UrdfFacts(root.get("name", ""), links, joints, transmissions, plugins, meshes)


@dataclass
class ModelPair:
    """A URDF and an MJCF that claim to describe the same robot. Load errors are kept, not raised:
    the check that needs a file reports it."""

    name: str
    urdf_path: Path
    mjcf_path: Path
    scene_path: Path | None = None
    urdf: UrdfFacts | None = None
    urdf_error: str | None = None
    model: Any = None  # mujoco.MjModel
    mjcf_error: str | None = None
    configuration: Configuration | None = None  # what the config that built it says, when known
    hand: HandId | None = None  # the hand the build wrote into its manifest (None: no manifest beside the MJCF)


def load_pair(urdf_path: Path, mjcf_path: Path, name: str | None = None, config_path: Path | None = None) -> ModelPair:
    import mujoco

    pair = ModelPair(name or mjcf_path.stem, urdf_path, mjcf_path)
    scene = mjcf_path.parent / "scene.xml"
    pair.scene_path = scene if scene.is_file() else None
    try:
        pair.urdf = read_urdf_facts(urdf_path)
    except (OSError, etree.XMLSyntaxError, ValueError, TypeError, AttributeError) as exc:
        pair.urdf_error = f"{type(exc).__name__}: {exc}"
    _refuse_nonfinite(mjcf_path)
    try:
        pair.model = mujoco.MjModel.from_xml_path(str(mjcf_path))
    except (ValueError, OSError) as exc:
        pair.mjcf_error = str(exc).strip().replace("\n", " ")
    model_name = _mjcf_model_name(mjcf_path) or pair.name
    if name is None:
        pair.name = model_name
    built = Model(model_name, mjcf_path.parent)
    pair.configuration = built.configuration(config_path)
    pair.hand = built.hand
    return pair


_NAME_ATTRIBUTES = frozenset(
    "name class childclass file model mesh material texture joint joint1 joint2 body body1 body2 geom geom1 geom2 "
    "site target tendon actuator objname objtype refname hfield content_type prefix key".split()
)


def _refuse_nonfinite(path: Path) -> None:
    """A nan or inf anywhere in the MJCF is refused before MuJoCo reads it (it would read it and diverge)."""
    try:
        root = etree.parse(str(path)).getroot()
    except (OSError, etree.XMLSyntaxError):
        return  # reported as the MJCF's load error
    for element in root.iter(etree.Element):
        for attribute, value in element.attrib.items():
            if attribute in _NAME_ATTRIBUTES:
                continue  # a body may be called "nan"
            for token in value.split():
                try:
                    finite = math.isfinite(float(token))
                except ValueError:
                    continue  # not a number
                if not finite:
                    name = element.get("name")
                    what = f"<{element.tag}{f' name={name!r}' if name else ''}>"
                    raise SvhdescError(f"{path}:{element.sourceline}: {what} {attribute}={value!r} is not finite")


def _mjcf_model_name(path: Path) -> str | None:
    try:
        return etree.parse(str(path)).getroot().get("model")
    except (OSError, etree.XMLSyntaxError):
        return None
