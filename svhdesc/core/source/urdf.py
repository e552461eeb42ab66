"""Expanded URDF (lxml tree) -> IR ``Robot``."""

from __future__ import annotations

import bisect
import functools
import math
import re
import warnings
from collections import Counter
from collections.abc import Collection, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from lxml import etree

from svhdesc.core import exact
from svhdesc.core.frames import rpy_matrix
from svhdesc.core.limits import depth_problem, links_problem
from svhdesc.core.source.packages import resolve_uri
from svhdesc.errors import SvhdescError
from svhdesc.ir import Geometry, Inertial, Joint, Link, Pose, Robot, Vec3

LARGEST = 1e9  # larger than any length, mass, limit or effort of a robot; small enough to compute with


def _floats(text: str | None, n: int, default: tuple[float, ...], where: str) -> tuple[float, ...]:
    if text is None:
        return default
    try:
        values = tuple(float(v) for v in text.split())
    except ValueError:
        raise SvhdescError(f"{where}: not a number list: {text!r}") from None
    if len(values) != n:
        raise SvhdescError(f"{where}: expected {n} numbers, got {text!r}")
    if not all(math.isfinite(v) for v in values):
        raise SvhdescError(f"{where}: non-finite number in {text!r}")
    if any(abs(v) > LARGEST for v in values):
        raise SvhdescError(f"{where}: implausibly large number in {text!r} (beyond +-{LARGEST:g})")
    return values


def _number(element: etree._Element | None, key: str, default: float | None, where: str) -> float:
    """A finite number attribute; ``default`` None: required."""
    text = element.get(key) if element is not None else None
    if text is None:
        if default is None:
            tag = element.tag if element is not None else "element"
            raise SvhdescError(f"{where}: <{tag}> needs a '{key}' attribute")
        return default
    return _floats(text, 1, (), f"{where}: {key}")[0]


def _sized(geometry: Geometry, where: str) -> Geometry | None:
    """A shape with sizes > 0; None (no shape, one warning) for one with a size 0, which has no extent to draw or
    collide with (the laikago of pybullet_data draws its toes as spheres of radius 0); a negative size is refused."""
    if any(v < 0 for v in geometry.size):
        raise SvhdescError(f"{where}: sizes must be > 0, got {geometry.size}")
    if not all(v > 0 for v in geometry.size):
        warnings.warn(f"{where}: a <{geometry.kind}> of size {geometry.size} has no extent: left out", stacklevel=3)
        return None
    return geometry


@dataclass(frozen=True)
class _Text:
    """A source file's text, where its lines start, and each tag's elements by name: read once per version."""

    text: str
    starts: tuple[int, ...]  # offsets of the lines' first characters
    names: dict[tuple[str, str], tuple[int, ...]]  # (tag, name) -> offsets of the elements' '<'

    def line(self, offset: int) -> int:
        return bisect.bisect_right(self.starts, offset)


@functools.lru_cache(maxsize=64)
def _indexed(file: Path, version: tuple[int, int]) -> _Text:
    text = file.read_text(encoding="utf-8", errors="replace")
    starts = (0, *(m.end() for m in re.finditer("\n", text)))
    names: dict[tuple[str, str], list[int]] = {}
    for tag in re.finditer(r"<[\w:.-]+\b[^>]*", text):  # every name= in a tag's attributes, as locate matches them
        for attribute in re.finditer(r'\bname="([^"]*)"', tag.group(0)):
            key = (tag.group(0)[1:].split(None, 1)[0], attribute.group(1))
            names.setdefault(key, []).append(tag.start())
    return _Text(text, starts, {key: tuple(offsets) for key, offsets in names.items()})


def _texts(files: Sequence[Path]) -> list[tuple[Path, _Text]]:
    """The files that can be read, each indexed once per (mtime, size): a URDF of 10,000 links asks 20,000 times."""
    found = []
    for file in files:
        try:
            stat = file.stat()
            found.append((file, _indexed(file, (stat.st_mtime_ns, stat.st_size))))
        except OSError:
            continue
    return found


def locate(files: Sequence[Path], tag: str, name: str | None, fallback: Path, nth: int = 1) -> str:
    """``file:line`` of the element ``<tag name=...>`` that expanded to ``name`` (xacro keeps no lines).

    Tries the literal name (from an index of each file, built once), then a macro-built one ending in the same
    suffix (``${prefix}_j3``), then a macro call passing that suffix (``<xacro:svh_fixed name="f2"``). ``nth``: the
    nth such element (the second of a duplicate), else the last one found.
    """
    if not name:
        return str(fallback)
    texts = _texts(files)
    found = [f"{file}:{text.line(offset)}" for file, text in texts for offset in text.names.get((tag, name), ())]
    if found:
        return found[min(nth, len(found)) - 1]
    tails = [name[i + 1 :] for i in range(1, len(name)) if name[i] == "_"]
    patterns = (
        [re.compile(rf'<{tag}\b[^>]*\bname="\$\{{[^}}"]+\}}_?{re.escape(tail)}"') for tail in tails]
        + [re.compile(rf'<xacro:\w+\b[^>]*\bname="{re.escape(tail)}"') for tail in tails]
        # a macro call passing the whole name in any argument (<xacro:ur5_body link="upper_arm_link" ...>)
        + [re.compile(rf'<xacro:\w+\b[^>]*\b[\w-]+="{re.escape(name)}"')]
    )
    for pattern in patterns:  # over the whole text: a tag may spread its attributes over lines (the double
        # pendulum writes <joint, name= and type= on lines of their own); the line is the tag's own
        found = [f"{file}:{text.line(match.start())}" for file, text in texts for match in pattern.finditer(text.text)]
        if found:
            return found[min(nth, len(found)) - 1]
    return str(fallback)


def _written_at(text: str, where: str) -> str:
    """``where`` ('file:line: link NAME') moved to the line of that file, at or below it, that holds ``text``
    literally (a mesh's URI: xacro keeps no lines); ``where`` itself when none does."""
    match = re.match(r"(.+):(\d+): (.*)$", where)
    if match is None:
        return where
    file, start, what = Path(match.group(1)), int(match.group(2)), match.group(3)
    texts = _texts([file])
    if not texts:
        return where
    indexed = texts[0][1]
    begin = indexed.starts[start - 1] if 0 < start <= len(indexed.starts) else len(indexed.text)
    at = indexed.text.find(f'"{text}"', begin)
    return f"{file}:{indexed.line(at)}: {what}" if at >= 0 else where


def _pose(element: etree._Element | None, where: str) -> Pose:
    if element is None:
        return Pose()
    return Pose(
        _floats(element.get("xyz"), 3, (0.0, 0.0, 0.0), where),  # type: ignore[arg-type]
        _floats(element.get("rpy"), 3, (0.0, 0.0, 0.0), where),  # type: ignore[arg-type]
    )


def _materials(root: etree._Element, files: Sequence[Path], source: Path) -> dict[str, tuple[float, ...]]:
    colours = {}
    for material in root.findall("material"):
        colour = material.find("color")
        name = material.get("name")
        if colour is not None and name:
            where = f"{locate(files, 'material', name, source)}: material {name}"
            colours[name] = _floats(colour.get("rgba"), 4, (0.5, 0.5, 0.5, 1.0), where)
    return colours


def _geometry(
    element: etree._Element,
    link: str,
    materials: dict[str, tuple[float, ...]],
    packages: Mapping[str, Path],
    source: Path,
    where: str,
) -> Geometry | None:
    origin = _pose(element.find("origin"), where)
    geometry = element.find("geometry")
    shape = [child for child in geometry if isinstance(child.tag, str)] if geometry is not None else []  # no comments
    if not shape:
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
        uri = shape[0].get("filename")
        if not uri:
            raise SvhdescError(f"{where}: <mesh> needs a 'filename'")
        where = _written_at(uri, where)
        path = resolve_uri(uri, packages, where)
        if not path.is_absolute():
            path = source.parent / path
        if not path.is_file():
            raise SvhdescError(f"{where}: mesh not found: {uri} ({path})")
        scale: Vec3 = _floats(shape[0].get("scale"), 3, (1.0, 1.0, 1.0), where)  # type: ignore[assignment]
        return Geometry("mesh", origin, mesh=str(path.resolve()), scale=scale, rgba=rgba)
    if kind == "box":
        if shape[0].get("size") is None:
            raise SvhdescError(f"{where}: <box> needs a 'size'")
        return _sized(Geometry("box", origin, _floats(shape[0].get("size"), 3, (), where), rgba=rgba), where)
    if kind == "cylinder":
        size = (_number(shape[0], "radius", None, where), _number(shape[0], "length", None, where))
        return _sized(Geometry("cylinder", origin, size, rgba=rgba), where)
    if kind == "sphere":
        return _sized(Geometry("sphere", origin, (_number(shape[0], "radius", None, where),), rgba=rgba), where)
    raise SvhdescError(f"{where}: unsupported geometry <{kind}>")


def _inertial(element: etree._Element | None, where: str) -> Inertial | None:
    if element is None:
        return None
    origin = _pose(element.find("origin"), where)
    if element.find("mass") is None or element.find("inertia") is None:
        raise SvhdescError(f"{where}: <inertial> needs <mass> and <inertia>")
    mass = _number(element.find("mass"), "value", None, where)
    inertia = element.find("inertia")
    ixx, ixy, ixz, iyy, iyz, izz = (_number(inertia, k, 0.0, where) for k in ("ixx", "ixy", "ixz", "iyy", "iyz", "izz"))
    tensor = np.array([[ixx, ixy, ixz], [ixy, iyy, iyz], [ixz, iyz, izz]])
    if any(origin.rpy):  # the IR keeps tensors in the link frame
        rotation = rpy_matrix(origin.rpy)
        tensor = exact.matmul(exact.matmul(rotation, tensor), rotation.T)
    values = (tensor[0, 0], tensor[0, 1], tensor[0, 2], tensor[1, 1], tensor[1, 2], tensor[2, 2])
    return Inertial(mass, origin.xyz, tuple(float(v) for v in values))  # type: ignore[arg-type]


def _shapes(
    elements: list, link: str, materials: dict, packages: Mapping[str, Path], source: Path, where: str
) -> tuple:
    found = (_geometry(e, link, materials, packages, source, where) for e in elements)
    return tuple(g for g in found if g is not None)


def _link(
    element: etree._Element,
    materials: dict[str, tuple[float, ...]],
    packages: Mapping[str, Path],
    source: Path,
    files: list[Path],
) -> Link:
    name = element.get("name")
    where = f"{locate(files, 'link', name, source)}: link {name}"
    if not name:
        raise SvhdescError(f"{where}: a link needs a name")
    return Link(
        name=name,
        inertial=_inertial(element.find("inertial"), where),
        visuals=_shapes(element.findall("visual"), name, materials, packages, source, where),
        collisions=_shapes(element.findall("collision"), name, materials, packages, source, where),
    )


def _joint_ends(element: etree._Element, where: str, links: Collection[str]) -> list[str]:
    ends = []
    for tag in ("parent", "child"):
        end = element.find(tag)
        if end is None or not end.get("link"):
            raise SvhdescError(f"{where}: needs <{tag} link=...>")
        if end.get("link") not in links:
            raise SvhdescError(f"{where}: unknown {tag} link '{end.get('link')}'")
        ends.append(end.get("link"))
    return ends


def _joint(element: etree._Element, name: str, where: str, links: Collection[str]) -> Joint:
    kind = element.get("type")
    if kind in {"floating", "planar"}:
        raise SvhdescError(
            f"{where}: type {kind!r} is not supported: svhdesc builds fixed-base robots (make the joint 'fixed', or "
            "drop it and its parent link, to fix the robot to the world)"
        )
    if kind not in {"revolute", "continuous", "prismatic", "fixed"}:
        raise SvhdescError(f"{where}: unsupported joint type {kind!r}")
    limit = element.find("limit")
    dynamics = element.find("dynamics")
    ends = _joint_ends(element, where, links)
    axis_element = element.find("axis")
    axis = _floats(axis_element.get("xyz") if axis_element is not None else None, 3, (1.0, 0.0, 0.0), where)
    if kind != "fixed" and math.hypot(*axis) < 1e-9:
        raise SvhdescError(f"{where}: zero joint axis {axis}")
    lower, upper = _limits(limit, kind, name, where)
    effort, velocity = _number(limit, "effort", 0.0, where), _number(limit, "velocity", 0.0, where)
    damping, friction = _number(dynamics, "damping", 0.0, where), _number(dynamics, "friction", 0.0, where)
    for label, value in (("effort", effort), ("velocity", velocity), ("damping", damping), ("friction", friction)):
        if value < 0:
            raise SvhdescError(f"{where}: {label} must be >= 0, got {value}")
    return Joint(
        name=name,
        type=kind,
        parent=ends[0],
        child=ends[1],
        origin=_pose(element.find("origin"), where),
        axis=axis,  # type: ignore[arg-type]
        lower=lower,
        upper=upper,
        effort=effort,
        velocity=velocity,
        damping=damping,
        friction=friction,
        source=where,
    )


class UnusableLimits(SvhdescError):
    """A joint's limits that no engine can use; read_urdf names every such joint in one line."""


def _limits(limit: etree._Element | None, kind: str, name: str, where: str) -> tuple[float, float]:
    """A revolute or prismatic joint's usable (lower, upper); a continuous joint has none (URDF ignores any it
    writes: (0, 0)), a fixed one needs none."""
    if kind == "continuous":
        return 0.0, 0.0
    try:
        lower, upper = _number(limit, "lower", 0.0, where), _number(limit, "upper", 0.0, where)
    except SvhdescError as exc:
        raise UnusableLimits(f"{exc}{_usable_limits(name, kind)}") from None
    if kind != "fixed" and lower > upper:
        raise UnusableLimits(
            f"{where}: lower limit {lower} is above the upper limit {upper}{_usable_limits(name, kind)}"
        )
    if kind != "fixed" and lower == upper:  # no range: pybullet reads it as no limit
        raise UnusableLimits(
            f"{where}: its limits give it no range ({lower:g} .. {upper:g}){_usable_limits(name, kind)}"
        )
    return lower, upper


def _usable_limits(joint: str, kind: str) -> str:
    """The settings that work around a joint's unusable limits (pybullet writes lower > upper, or +-1e16, for "no
    limit"; centauro's wheels are revolute joints without limits, "actually continuous"): limits of its own, a
    revolute joint turning without end, or the joint locked."""
    endless = (
        f"; a joint that turns without end (a wheel, a rotor): joints.{joint}.type: continuous (--joint "
        f"{joint}.type=continuous)"
        if kind == "revolute"
        else ""
    )
    return (
        f": give it usable limits with joints.{joint}.lower and .upper in the config (svhdesc init --joint "
        f"{joint}.lower=L --joint {joint}.upper=U){endless}; or lock it with joints.{joint}.type: fixed"
    )


@dataclass(frozen=True)
class SourceMimic:
    """A ``<mimic joint= multiplier= offset=>`` tag of the source: joint = multiplier * leader + offset."""

    joint: str
    leader: str
    multiplier: float
    offset: float
    where: str  # file:line of the joint


def read_mimics(root: etree._Element, source: Path, files: Sequence[Path] = ()) -> list[SourceMimic]:
    """The source's mimic tags, in document order (read_urdf drops them: the coupling spec decides; without
    one, they become it)."""
    files = list(files) or [source]
    found = []
    for element in root.findall("joint"):
        tag = element.find("mimic")
        if tag is None:
            continue
        name = element.get("name")
        where = f"{locate(files, 'joint', name, source)}: joint {name}"
        leader = tag.get("joint")
        if not leader:
            raise SvhdescError(f"{where}: <mimic> needs joint=...")
        factor, offset = _number(tag, "multiplier", 1.0, where), _number(tag, "offset", 0.0, where)
        found.append(SourceMimic(str(name), leader, factor, offset, where))
    return found


def read_urdf(root: etree._Element, packages: Mapping[str, Path], source: Path, files: Sequence[Path] = ()) -> Robot:
    """Read links and joints; mimic tags in the source are dropped (the coupling spec decides).

    ``files`` (the xacro files expanded) let errors name the file and line of the culprit.
    """
    files = list(files) or [source]
    too_many = links_problem(len(root.findall("link")))
    if too_many is not None:  # before each link is read
        raise SvhdescError(f"{source}: {too_many}")
    materials = _materials(root, files, source)
    links = [_link(element, materials, packages, source, files) for element in root.findall("link")]
    names = [link.name for link in links]
    known = set(names)  # looked up for each joint's two ends: a list made 10,000 links quadratic
    if len(known) != len(names):
        counts = Counter(names)
        dup = next(n for n in names if counts[n] > 1)
        raise SvhdescError(f"{locate(files, 'link', dup, source, nth=2)}: duplicate link '{dup}'")
    joints, unusable = [], []
    joint_names: set[str] = set()
    for element in root.findall("joint"):
        name = element.get("name")
        where = f"{locate(files, 'joint', name, source)}: joint {name}"
        if not name:
            raise SvhdescError(f"{where}: a joint needs a name")
        if name in joint_names:
            raise SvhdescError(f"{locate(files, 'joint', name, source, nth=2)}: duplicate joint '{name}'")
        joint_names.add(name)
        try:
            joints.append(_joint(element, name, where, known))
        except UnusableLimits as exc:
            unusable.append((exc, name))
    if unusable:  # one line for all of them (minitaur's eight knees), the first's file:line
        more = [name for _, name in unusable[1:]]
        raise SvhdescError(f"{unusable[0][0]}" + (f" (and the same for {', '.join(more)})" if more else ""))
    children = {j.child for j in joints}
    roots = [n for n in names if n not in children]
    if len(roots) != 1:
        raise SvhdescError(f"{source}: expected one root link, found {roots}")
    too_big = depth_problem({j.child: j.parent for j in joints})
    if too_big is not None:  # before any stage walks the tree
        raise SvhdescError(f"{source}: {too_big}")
    return Robot(name=root.get("name", source.stem), links=tuple(links), joints=tuple(joints), root=roots[0])
