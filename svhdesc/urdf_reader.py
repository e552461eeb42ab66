"""Expanded URDF (lxml tree) -> IR ``Robot``."""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path

import numpy as np
from lxml import etree

from .errors import SvhdescError
from .ir import Geometry, Inertial, Joint, Link, Pose, Robot, Vec3
from .packages import resolve_uri
from .stages.frames import rpy_matrix


def _floats(text: str | None, n: int, default: tuple[float, ...], where: str) -> tuple[float, ...]:
    if text is None:
        return default
    try:
        values = tuple(float(v) for v in text.split())
    except ValueError:
        raise SvhdescError(f"{where}: not a number list: {text!r}") from None
    if len(values) != n:
        raise SvhdescError(f"{where}: expected {n} numbers, got {text!r}")
    return values


def _pose(element: etree._Element | None, where: str) -> Pose:
    if element is None:
        return Pose()
    return Pose(
        _floats(element.get("xyz"), 3, (0.0, 0.0, 0.0), where),  # type: ignore[arg-type]
        _floats(element.get("rpy"), 3, (0.0, 0.0, 0.0), where),  # type: ignore[arg-type]
    )


def _materials(root: etree._Element) -> dict[str, tuple[float, float, float, float]]:
    colours = {}
    for material in root.findall("material"):
        colour = material.find("color")
        if colour is not None and material.get("name"):
            colours[material.get("name")] = _floats(colour.get("rgba"), 4, (0.5, 0.5, 0.5, 1.0), "material")
    return colours


def _geometry(
    element: etree._Element,
    link: str,
    materials: dict,
    packages: Mapping[str, Path],
    source: Path,
) -> Geometry:
    where = f"{source}: link {link}"
    origin = _pose(element.find("origin"), where)
    shape = element.find("geometry")
    if shape is None or len(shape) == 0:
        raise SvhdescError(f"{where}: {element.tag} without geometry")
    kind = shape[0].tag
    rgba = None
    material = element.find("material")
    if material is not None:
        colour = material.find("color")
        if colour is not None:
            rgba = _floats(colour.get("rgba"), 4, (0.5, 0.5, 0.5, 1.0), where)
        else:
            rgba = materials.get(material.get("name", ""))
    if kind == "mesh":
        uri = shape[0].get("filename", "")
        path = resolve_uri(uri, packages, where)
        if not path.is_absolute():
            path = source.parent / path
        if not path.is_file():
            raise SvhdescError(f"{where}: mesh not found: {uri} ({path})")
        scale: Vec3 = _floats(shape[0].get("scale"), 3, (1.0, 1.0, 1.0), where)  # type: ignore[assignment]
        return Geometry("mesh", origin, mesh=str(path.resolve()), scale=scale, rgba=rgba)
    if kind == "box":
        return Geometry("box", origin, _floats(shape[0].get("size"), 3, (), where), rgba=rgba)
    if kind == "cylinder":
        size = (float(shape[0].get("radius")), float(shape[0].get("length")))
        return Geometry("cylinder", origin, size, rgba=rgba)
    if kind == "sphere":
        return Geometry("sphere", origin, (float(shape[0].get("radius")),), rgba=rgba)
    raise SvhdescError(f"{where}: unsupported geometry <{kind}>")


def _inertial(element: etree._Element | None, where: str) -> Inertial | None:
    if element is None:
        return None
    origin = _pose(element.find("origin"), where)
    mass = float(element.find("mass").get("value"))
    inertia = element.find("inertia")
    ixx, ixy, ixz, iyy, iyz, izz = (float(inertia.get(k, "0")) for k in ("ixx", "ixy", "ixz", "iyy", "iyz", "izz"))
    tensor = np.array([[ixx, ixy, ixz], [ixy, iyy, iyz], [ixz, iyz, izz]])
    if any(origin.rpy):  # the IR keeps tensors in the link frame
        rotation = rpy_matrix(origin.rpy)
        tensor = rotation @ tensor @ rotation.T
    values = (tensor[0, 0], tensor[0, 1], tensor[0, 2], tensor[1, 1], tensor[1, 2], tensor[2, 2])
    return Inertial(mass, origin.xyz, tuple(float(v) for v in values))  # type: ignore[arg-type]


def read_urdf(root: etree._Element, packages: Mapping[str, Path], source: Path) -> Robot:
    """Read links and joints; mimic tags in the source are dropped (the coupling spec decides)."""
    materials = _materials(root)
    links = []
    for element in root.findall("link"):
        name = element.get("name")
        where = f"{source}: link {name}"
        links.append(
            Link(
                name=name,
                inertial=_inertial(element.find("inertial"), where),
                visuals=tuple(_geometry(v, name, materials, packages, source) for v in element.findall("visual")),
                collisions=tuple(_geometry(c, name, materials, packages, source) for c in element.findall("collision")),
            )
        )
    names = [link.name for link in links]
    if len(set(names)) != len(names):
        dup = next(n for n in names if names.count(n) > 1)
        raise SvhdescError(f"{source}: duplicate link '{dup}'")
    joints = []
    for element in root.findall("joint"):
        name = element.get("name")
        where = f"{source}: joint {name}"
        kind = element.get("type")
        if kind not in {"revolute", "continuous", "prismatic", "fixed"}:
            raise SvhdescError(f"{where}: unsupported joint type {kind!r}")
        limit = element.find("limit")
        dynamics = element.find("dynamics")

        def attr(el: etree._Element | None, key: str, default: float) -> float:
            return float(el.get(key, default)) if el is not None else default

        parent, child = element.find("parent").get("link"), element.find("child").get("link")
        for link_name in (parent, child):
            if link_name not in names:
                raise SvhdescError(f"{where}: unknown link '{link_name}'")
        joints.append(
            Joint(
                name=name,
                type=kind,
                parent=parent,
                child=child,
                origin=_pose(element.find("origin"), where),
                axis=_floats(
                    element.find("axis").get("xyz") if element.find("axis") is not None else None,
                    3,
                    (1.0, 0.0, 0.0),
                    where,
                ),  # type: ignore[arg-type]
                lower=attr(limit, "lower", 0.0),
                upper=attr(limit, "upper", 0.0),
                effort=attr(limit, "effort", 0.0),
                velocity=attr(limit, "velocity", 0.0),
                damping=attr(dynamics, "damping", 0.0),
                friction=attr(dynamics, "friction", 0.0),
                source=where,
            )
        )
    children = {j.child for j in joints}
    roots = [n for n in names if n not in children]
    if len(roots) != 1:
        raise SvhdescError(f"{source}: expected one root link, found {roots}")
    return Robot(name=root.get("name", source.stem), links=tuple(links), joints=tuple(joints), root=roots[0])
