"""The static tier on a URDF as it stands: the file's own numbers, each fault a finding at its file:line.

Read with lxml (its source lines) and checked by rules written here, not by the compiler's reader: a validator that
ran a user's file through svhdesc's own importer would refuse it at the first fault instead of reporting them all,
and would substitute guesses for the values it is meant to judge.
"""

from __future__ import annotations

import functools
import math
import os
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from lxml import etree

from svhdesc.core.limits import mesh_size_problem
from svhdesc.core.source.urdf import locate
from svhdesc.validate.findings import Finding

MOVABLE = {"revolute", "continuous", "prismatic"}
LIMITED = {"revolute", "prismatic"}
# A collision mesh whose bounding box is this many times its visual's diagonal is a unit or scale slip (mm for m).
COLLISION_SCALE_BOUND = 10.0
# A follower may overshoot its limit by what rounding its limit to 4 decimals leaves (the vendor's SVH xacro: 0.9704 x
# 1.44889 = 1.4060026 against an upper limit of 1.406), not by more.
MIMIC_SLACK = 1e-4
_COUNTS = {"xyz": 3, "rpy": 3, "scale": 3}
STATIC_URDF_CHECKS = ("xml", "structure", "numbers", "inertials", "joint_limits", "mimic", "meshes")


@dataclass(frozen=True)
class UrdfSource:
    path: Path
    root: etree._Element
    packages: dict[str, Path]
    # The files a xacro expansion read (the source first): the expanded tree keeps no lines, so a finding is placed
    # at the line of the <link>/<joint> that expanded to its element, found in these files.
    xacro_files: tuple[Path, ...] = ()

    def where(self, element: etree._Element | None) -> tuple[str, int | None]:
        if not self.xacro_files:
            return str(self.path), element.sourceline if element is not None else None
        owner = element
        while owner is not None and not (owner.tag in {"link", "joint"} and owner.get("name")):
            owner = owner.getparent()
        if owner is None:
            return str(self.path), None
        located = locate(self.xacro_files, owner.tag, owner.get("name"), self.path)
        file, _, line = located.rpartition(":")
        return (file, int(line)) if line.isdigit() else (located, None)


Rule = Callable[[UrdfSource], list[Finding]]


def _finding(source: UrdfSource, check: str, element: etree._Element | None, message: str, remedy: str = "") -> Finding:
    file, line = source.where(element)
    return Finding(check, file, line, message, remedy)


def _floats(text: str | None) -> list[float] | None:
    if text is None:
        return None
    try:
        return [float(v) for v in text.split()]
    except ValueError:
        return None


def check_structure(source: UrdfSource) -> list[Finding]:
    """References, duplicate names, a link with two parents, loops, one root."""
    found: list[Finding] = []
    links = source.root.findall("link")
    joints = source.root.findall("joint")
    names: dict[str, etree._Element] = {}
    for kind, elements in (("link", links), ("joint", joints)):
        seen: dict[str, etree._Element] = {}
        for element in elements:
            name = element.get("name")
            if not name:
                found.append(_finding(source, "structure", element, f"a <{kind}> without a name"))
            elif name in seen:
                first = seen[name].sourceline
                found.append(
                    _finding(source, "structure", element, f"{kind} '{name}' defined twice (first at line {first})")
                )
            else:
                seen[name] = element
        if kind == "link":
            names = seen
    parent_of: dict[str, str] = {}
    for joint in joints:
        name = joint.get("name", "?")
        ends = {}
        for end in ("parent", "child"):
            element = joint.find(end)
            link = element.get("link") if element is not None else None
            if link is None:
                found.append(_finding(source, "structure", joint, f"joint '{name}' has no <{end} link=...>"))
            elif link not in names:
                found.append(
                    _finding(source, "structure", element, f"joint '{name}': {end} link '{link}' is not defined")
                )
            ends[end] = link
        child, parent = ends.get("child"), ends.get("parent")
        if child is None or parent is None:
            continue
        if child in parent_of:
            found.append(
                _finding(
                    source,
                    "structure",
                    joint,
                    f"link '{child}' has two parents ('{parent_of[child]}', '{parent}'): a loop",
                )
            )
        else:
            parent_of[child] = parent
    found.extend(_cycles_and_roots(source, names, parent_of))
    found.extend(_repeated(source))
    return found


# Elements a URDF allows once in their parent (urdfdom reads the first and MuJoCo refuses the file).
_ONCE = {
    "joint": ("parent", "child", "origin", "axis", "limit", "mimic", "dynamics", "calibration", "safety_controller"),
    "link": ("inertial",),
    "inertial": ("origin", "mass", "inertia"),
}


def _repeated(source: UrdfSource) -> list[Finding]:
    found = []
    for owner in source.root.iter(*_ONCE):
        parent = owner.getparent()
        if (parent is not source.root) if owner.tag != "inertial" else (parent is None or parent.tag != "link"):
            continue  # a <transmission>'s or <gazebo> block's own vocabulary
        for tag in _ONCE[owner.tag]:
            repeats = owner.findall(tag)
            for extra in repeats[1:]:
                what = f"{owner.tag} '{owner.get('name')}'" if owner.get("name") else f"<{owner.tag}>"
                message = f"{what}: a second <{tag}> (first at line {repeats[0].sourceline}); one is allowed"
                found.append(_finding(source, "structure", extra, message))
    return found


def _on_cycles(names: dict[str, etree._Element], parent_of: dict[str, str]) -> set[str]:
    """The links that are their own ancestors: each link's walk to the root stops at a link walked before, so the
    whole is linear in the links (a walk from every link to the root was quadratic: 27 s on a 10,000-link chain)."""
    state: dict[str, int] = {}  # 1: on the walk under way, 2: walked before
    cycles: set[str] = set()
    for start in names:
        path, link = [], start
        while link is not None and link not in state:
            state[link] = 1
            path.append(link)
            link = parent_of.get(link)
        if link is not None and state[link] == 1:  # the walk came back onto itself: the links from there are a cycle
            cycles.update(path[path.index(link) :])
        for walked in path:
            state[walked] = 2
    return cycles


def _cycles_and_roots(source: UrdfSource, names: dict[str, etree._Element], parent_of: dict[str, str]) -> list[Finding]:
    on_cycles = _on_cycles(names, parent_of)
    found = [
        _finding(source, "structure", names[start], f"link '{start}' is its own ancestor: a cycle")
        for start in names
        if start in on_cycles
    ]
    roots = [name for name in names if name not in parent_of]
    if len(names) and len(roots) != 1 and not found:
        listed = ", ".join(roots[:6])
        found.append(
            _finding(source, "structure", source.root, f"{len(roots)} root links ({listed}): a URDF is one tree")
        )
    return found


def check_numbers(source: UrdfSource) -> list[Finding]:
    """Every number parses and is finite (origins, axes, inertias, limits, mimic)."""
    numeric = {
        "origin": ("xyz", "rpy"),
        "axis": ("xyz",),
        "mass": ("value",),
        "inertia": ("ixx", "ixy", "ixz", "iyy", "iyz", "izz"),
        "limit": ("lower", "upper", "effort", "velocity"),
        "mimic": ("multiplier", "offset"),
        "dynamics": ("damping", "friction"),
        "mesh": ("scale",),
    }
    found = []
    for element in source.root.iter(*numeric):
        for attribute in numeric[element.tag]:
            text = element.get(attribute)
            if text is None:
                continue
            values = _floats(text)
            if values is None or not all(math.isfinite(v) for v in values):
                found.append(
                    _finding(source, "numbers", element, f'<{element.tag} {attribute}="{text}">: not a finite number')
                )
            elif len(values) != _COUNTS.get(attribute, 1):
                found.append(
                    _finding(
                        source,
                        "numbers",
                        element,
                        f'<{element.tag} {attribute}="{text}">: {len(values)} numbers, not {_COUNTS.get(attribute, 1)}',
                    )
                )
    return found


def _inertial_values(inertial: etree._Element) -> tuple[float | None, np.ndarray | None]:
    mass_element, inertia = inertial.find("mass"), inertial.find("inertia")
    mass = _floats(mass_element.get("value")) if mass_element is not None else None
    keys = ("ixx", "ixy", "ixz", "iyy", "iyz", "izz")
    values = [_floats(inertia.get(k, "0")) for k in keys] if inertia is not None else None
    matrix = None
    if values is not None and all(v and math.isfinite(v[0]) for v in values if v is not None) and None not in values:
        ixx, ixy, ixz, iyy, iyz, izz = (v[0] for v in values)  # type: ignore[index]
        matrix = np.array([[ixx, ixy, ixz], [ixy, iyy, iyz], [ixz, iyz, izz]])
    return (mass[0] if mass and math.isfinite(mass[0]) else None), matrix


def check_inertials(source: UrdfSource) -> list[Finding]:
    """Masses > 0, inertias positive definite and within the triangle inequality, every moving link with mass."""
    found = []
    massive: set[str] = set()
    for link in source.root.findall("link"):
        inertial = link.find("inertial")
        if inertial is None:
            continue
        name = link.get("name", "?")
        mass, matrix = _inertial_values(inertial)
        mass_element = inertial.find("mass")
        if mass is None or mass < 0:
            shown = "missing" if mass is None else f"{mass:g}"
            where = mass_element if mass_element is not None else inertial
            found.append(_finding(source, "inertials", where, f"link '{name}': mass {shown}, must be >= 0"))
            continue
        if mass == 0:  # a frame or a fixed base (pybullet's convention): judged by what moves, below
            continue
        massive.add(name)
        if matrix is None:
            found.append(_finding(source, "inertials", inertial, f"link '{name}': <inertia> missing or unreadable"))
            continue
        found.extend(_inertia_findings(source, name, inertial.find("inertia"), matrix))
    found.extend(_massless_moving(source, massive))
    return found


def _inertia_findings(source: UrdfSource, name: str, element: etree._Element, matrix: np.ndarray) -> list[Finding]:
    moments = np.linalg.eigvalsh(matrix)
    if moments[0] <= 0:
        return [
            _finding(
                source,
                "inertials",
                element,
                f"link '{name}': inertia not positive definite "
                f"(principal moments {', '.join(f'{m:.3g}' for m in moments)})",
            )
        ]
    a, b, c = moments
    slack = 1e-6 * c
    if a + b < c - slack:
        return [
            _finding(
                source,
                "inertials",
                element,
                f"link '{name}': principal moments {a:.3g} + {b:.3g} < {c:.3g} break the triangle inequality",
                f"largest moment at most {a + b:.6g}",
            )
        ]
    return []


def _massless_moving(source: UrdfSource, massive: set[str]) -> list[Finding]:
    """A movable joint's child, with what hangs on it by fixed joints, weighing nothing: no engine can move it."""
    children: dict[str, list[tuple[str, str]]] = {}
    for joint in source.root.findall("joint"):
        parent, child = joint.find("parent"), joint.find("child")
        if parent is not None and child is not None:
            children.setdefault(parent.get("link", ""), []).append((child.get("link", ""), joint.get("type", "")))
    found = []
    for joint in source.root.findall("joint"):
        child = joint.find("child")
        if joint.get("type") not in MOVABLE or child is None:
            continue
        stack, carries = [child.get("link", "")], False
        while stack and not carries:
            link = stack.pop()
            carries = link in massive
            stack.extend(c for c, kind in children.get(link, []) if kind == "fixed")
        if not carries:
            found.append(
                _finding(
                    source,
                    "inertials",
                    joint,
                    f"joint '{joint.get('name')}' moves link '{child.get('link')}', "
                    "which has no <inertial> (nor any link fixed to it)",
                )
            )
    return found


def check_joint_limits(source: UrdfSource) -> list[Finding]:
    """Limits present where the type needs them, ordered, a range that moves, effort and velocity > 0."""
    found = []
    for joint in source.root.findall("joint"):
        kind, name = joint.get("type"), joint.get("name", "?")
        if kind not in MOVABLE:
            continue
        limit = joint.find("limit")
        if limit is None:
            if kind in LIMITED:
                found.append(_finding(source, "joint_limits", joint, f"{kind} joint '{name}' has no <limit>"))
            continue
        values = {k: (_floats(limit.get(k)) or [None])[0] for k in ("lower", "upper", "effort", "velocity")}
        lower, upper = values["lower"] or 0.0, values["upper"] or 0.0
        if kind in LIMITED and lower > upper:
            found.append(
                _finding(
                    source,
                    "joint_limits",
                    limit,
                    f"joint '{name}': lower {lower:g} > upper {upper:g} (inverted)",
                    f'lower="{upper:g}" upper="{lower:g}"',
                )
            )
        elif kind in LIMITED and lower == upper:
            found.append(
                _finding(
                    source, "joint_limits", limit, f"{kind} joint '{name}': lower = upper = {lower:g}, it cannot move"
                )
            )
        for key in ("effort", "velocity"):
            value = values[key]
            if value is None:
                found.append(_finding(source, "joint_limits", limit, f"joint '{name}': no {key} in <limit>"))
            elif value <= 0:
                found.append(_finding(source, "joint_limits", limit, f"joint '{name}': {key} {value:g}, must be > 0"))
    return found


def _range(joint: etree._Element) -> tuple[float, float] | None:
    limit = joint.find("limit")
    if joint.get("type") not in LIMITED or limit is None:
        return None
    lower, upper = ((_floats(limit.get(key)) or [None])[0] for key in ("lower", "upper"))
    if lower is None or upper is None or not (math.isfinite(lower) and math.isfinite(upper)) or lower > upper:
        return None
    return lower, upper


def check_mimic(source: UrdfSource) -> list[Finding]:
    """Each <mimic> names a movable joint, and the follower's limits hold the leader's range through it."""
    joints = {j.get("name"): j for j in source.root.findall("joint")}
    found = []
    for follower in joints.values():
        mimic = follower.find("mimic")
        if mimic is None:
            continue
        name, leader_name = follower.get("name"), mimic.get("joint")
        leader = joints.get(leader_name)
        if leader is None:
            found.append(
                _finding(source, "mimic", mimic, f"joint '{name}' mimics '{leader_name}', which is not defined")
            )
            continue
        if leader.get("type") not in MOVABLE:
            found.append(
                _finding(source, "mimic", mimic, f"joint '{name}' mimics '{leader_name}', a {leader.get('type')} joint")
            )
            continue
        leads, follows = _range(leader), _range(follower)
        if leads is None or follows is None:
            continue
        multiplier = (_floats(mimic.get("multiplier")) or [1.0])[0]
        offset = (_floats(mimic.get("offset")) or [0.0])[0]
        ends = sorted(multiplier * q + offset for q in leads)
        if ends[0] < follows[0] - MIMIC_SLACK or ends[1] > follows[1] + MIMIC_SLACK:
            found.append(
                _finding(
                    source,
                    "mimic",
                    follower.find("limit"),
                    f"joint '{name}' follows '{leader_name}' to {ends[0]:.6g} .. {ends[1]:.6g}, beyond its limits "
                    f"{follows[0]:.6g} .. {follows[1]:.6g}",
                    f'lower="{min(follows[0], ends[0]):.6g}" upper="{max(follows[1], ends[1]):.6g}"',
                )
            )
    return found


def resolve_mesh(uri: str, source: UrdfSource) -> Path | None:
    """A mesh's filename as ROS resolves it: package:// through the given packages, ROS_PACKAGE_PATH and the folders
    above the file; file:// and plain paths from the URDF's folder. None: a package no one provides."""
    from svhdesc.core.source.packages import find_beside

    if uri.startswith("package://"):
        package, _, rest = uri[len("package://") :].lstrip("/").partition("/")
        folder = source.packages.get(package)
        for root in os.environ.get("ROS_PACKAGE_PATH", "").split(os.pathsep):
            if folder is None and root and (Path(root) / package).is_dir():
                folder = Path(root) / package
        folder = folder or find_beside(package, source.path)
        return folder / rest if folder is not None else None
    path = Path(uri.removeprefix("file://"))
    return path if path.is_absolute() else source.path.parent / path


def _unusable(path: Path) -> str | None:
    """Why a mesh file is not read: missing, not a regular file, or too big (minutes and gigabytes), or None."""
    if not path.is_file():
        return "missing" if not path.exists() else "not a regular file"
    return mesh_size_problem(path)


def check_meshes(source: UrdfSource) -> list[Finding]:
    """Every mesh resolves to a readable regular file, and no collision mesh dwarfs its link's visuals."""
    found = []
    extents: dict[tuple[str, str], list[float]] = {}
    collisions: dict[str, list[etree._Element]] = {}
    for link in source.root.findall("link"):
        for role in ("visual", "collision"):
            for mesh in link.findall(f"{role}/geometry/mesh"):
                uri = mesh.get("filename", "")
                path = resolve_mesh(uri, source)
                if path is None:
                    package = uri[len("package://") :].lstrip("/").partition("/")[0]
                    found.append(
                        _finding(
                            source,
                            "meshes",
                            mesh,
                            f"mesh '{uri}': package '{package}' not found",
                            f"--package {package}=DIR",
                        )
                    )
                elif (unusable := _unusable(path)) is not None:
                    found.append(_finding(source, "meshes", mesh, f"mesh '{uri}': {path} is {unusable}"))
                else:
                    size = _mesh_diagonal(path, mesh.get("scale"))
                    if size is None:
                        found.append(_finding(source, "meshes", mesh, f"mesh '{uri}': {path} does not load"))
                    elif math.isfinite(size):
                        extents.setdefault((link.get("name", "?"), role), []).append(size)
                        if role == "collision":
                            collisions.setdefault(link.get("name", "?"), []).append(mesh)
    for (link, role), sizes in extents.items():
        visual = extents.get((link, "visual"))
        if role != "collision" or not visual or max(visual) <= 0:  # 0: every visual vertex at one point
            continue
        ratio = max(sizes) / max(visual)
        if ratio > COLLISION_SCALE_BOUND:
            found.append(
                _finding(
                    source,
                    "meshes",
                    collisions[link][int(np.argmax(sizes))],
                    f"link '{link}': collision mesh {ratio:.3g} x the size of its visual "
                    f"(bound {COLLISION_SCALE_BOUND:g} x)",
                )
            )
    return found


def _mesh_diagonal(path: Path, scale: str | None) -> float | None:
    """The scaled mesh's bounding-box diagonal; None when it does not load, nan when it holds no triangles."""
    try:
        stat = path.stat()
    except OSError:
        return None
    bounds = _mesh_bounds(str(path), stat.st_size, stat.st_mtime_ns)
    if bounds is None or not isinstance(bounds, np.ndarray):
        return bounds
    factors = np.array(_floats(scale) or [1.0, 1.0, 1.0])
    if factors.shape != (3,):  # a malformed scale is the numbers check's finding; judge the size unscaled
        factors = np.ones(3)
    if bounds.shape != (2, 3) or not np.all(np.isfinite(bounds)):
        return None
    return float(np.linalg.norm((bounds[1] - bounds[0]) * np.abs(factors)))


@functools.lru_cache(maxsize=4096)
def _mesh_bounds(path: str, size: int, mtime_ns: int) -> np.ndarray | float | None:
    """A mesh file's bounds, read once per process and version of the file (links and models share meshes)."""
    try:
        import trimesh

        loaded = trimesh.load(path, force="mesh", process=False)
    except Exception:  # any reader's failure is the finding "does not load"
        return None
    if loaded.bounds is None:  # read, but no triangles trimesh takes (a COLLADA of lines, say): no size to judge
        return math.nan
    bounds = np.asarray(loaded.bounds, dtype=float)
    bounds.setflags(write=False)
    return bounds


RULES: dict[str, Rule] = {
    "structure": check_structure,
    "numbers": check_numbers,
    "inertials": check_inertials,
    "joint_limits": check_joint_limits,
    "mimic": check_mimic,
    "meshes": check_meshes,
}
