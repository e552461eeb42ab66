"""``svhdesc init``: a commented starter config (and coupling spec) for a third-party URDF or xacro.

The config is YAML text with comments (the values themselves go through yaml.safe_dump, so any joint or link
name is quoted as YAML needs); it builds and validates unedited: every movable joint is driven (arm joints,
or channels and coupled joints from the source's ``<mimic>`` tags), ``home`` lies inside every limit, and the
packages the meshes name are found beside the source.
"""

from __future__ import annotations

import importlib.util
import math
import os
import textwrap
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np
import trimesh
import yaml
from lxml import etree

from svhdesc.compiler.assets import Assets
from svhdesc.compiler.drives import STIFF_AT, Drive, cap_stiffness, size_drive
from svhdesc.compiler.loads import Load, joint_loads, link_frames, mobilities
from svhdesc.compiler.stages.inertials import cylinder_inertial, shape_of
from svhdesc.core import exact
from svhdesc.core.frames import pose_matrix
from svhdesc.core.halton import halton
from svhdesc.core.inertia import inertial_problem
from svhdesc.core.limits import mesh_size_problem
from svhdesc.core.settings.config import PYTHON, package_name
from svhdesc.core.settings.coupling import CouplingSpec, spec_from_mimics
from svhdesc.core.settings.schema import JointDynamics, Simulation
from svhdesc.core.source.meshes import MeshError, MeshTooBig, load_mesh
from svhdesc.core.source.packages import find_beside
from svhdesc.core.source.quirks import apply_joint_quirks, clashing_names
from svhdesc.core.source.urdf import read_mimics, read_urdf
from svhdesc.core.source.xacro import expand_xacro
from svhdesc.errors import SvhdescError
from svhdesc.ir import Geometry, Inertial, Joint, Link, Robot

ARMATURE = 0.1  # kg m^2 or kg: the channels' and coupled joints' armature
GUESSED_MASS = 0.1  # kg: a link with geometry and no inertial in the source (init says so; weigh it)
HOME_CLEARANCE = 0.1  # of a joint's range: how far `home` keeps clear of its stops
GUESS_POSES = 16  # poses besides home over which an unrated joint's gravity load is the worst (its guessed drive)


@dataclass(frozen=True)
class Starter:
    config: str  # YAML text
    coupling: str | None  # YAML text of the coupling spec, None without <mimic> tags


def _written_path(path: Path, config_dir: Path) -> str:
    """``python:MODULE/SUB`` where ``path`` lies inside an installed Python package (a wheel's data), else
    the path relative to the config's folder."""
    path = path.resolve()
    for parent in path.parents:
        spec = importlib.util.find_spec(parent.name) if parent.name.isidentifier() else None
        locations = list(spec.submodule_search_locations or []) if spec is not None else []
        if locations and Path(locations[0]).resolve() == parent:
            return f"{PYTHON}{parent.name}/{path.relative_to(parent).as_posix()}"
    return Path(os.path.relpath(path, config_dir.resolve())).as_posix()


def _mesh_packages(tree: etree._Element) -> list[str]:
    uris = [m.get("filename", "") for m in tree.iter("mesh")]
    # package:///NAME/... (Talos' full model writes an empty authority) names NAME, as resolve_uri reads it
    found = {u[len("package://") :].lstrip("/").partition("/")[0] for u in uris if u.startswith("package://")}
    return sorted(found)


def _packages(tree: etree._Element, source: Path, given: dict[str, Path]) -> dict[str, Path]:
    packages = dict(given)
    for name in _mesh_packages(tree):
        if name in packages:
            continue
        found = find_beside(name, source) if name else None
        if found is None:
            raise SvhdescError(
                f"{source}: its meshes name package '{name}', found neither above the source nor given "
                f"(add --package {name}=DIR)"
            )
        packages[name] = found
    return packages


def _check_meshes(robot: Robot) -> None:
    for link in robot.links:
        for geometry in (*link.visuals, *link.collisions):
            path = Path(geometry.mesh) if geometry.kind == "mesh" and geometry.mesh else None
            if path is not None and not (path.is_file() and os.access(path, os.R_OK)):
                raise SvhdescError(f"link {link.name}: mesh {path} is missing or unreadable")
            too_big = mesh_size_problem(path) if path is not None else None
            if too_big is not None:  # the build would refuse it: said before a config is written
                raise SvhdescError(f"link {link.name}: mesh {path} is {too_big}")


def _read(source: Path, given: dict[str, Path], quirks: dict[str, Any]) -> tuple[Robot, list, dict[str, Path]]:
    if not source.is_file():
        raise SvhdescError(f"{source}: no such file")
    tree, inputs = expand_xacro(source, {}, given)
    if tree.tag != "robot":
        raise SvhdescError(f"{source}: not a URDF (its root element is <{tree.tag}>, not <robot>)")
    for name, new in clashing_names(tree).items():  # SDFormat refuses a joint named like a link: renamed, and said
        if name not in quirks:
            quirks[name] = JointDynamics(rename=new)
    apply_joint_quirks(tree, quirks, {name: "--joint" for name in quirks})
    packages = _packages(tree, source, given)
    robot = read_urdf(tree, packages, source, inputs)
    _check_meshes(robot)
    return robot, read_mimics(tree, source, inputs), packages


def _home(joint: Joint) -> float:
    """0 where it lies HOME_CLEARANCE of the range clear of both stops; else the nearest such point where 0 is in the
    range (the Panda's wrist, 0 at 0.0175 rad from its stop: 0.37); else the middle of the range."""
    if joint.type == "continuous":
        return 0.0
    if not joint.lower <= 0.0 <= joint.upper:
        return round((joint.lower + joint.upper) / 2, 6)
    clear = HOME_CLEARANCE * (joint.upper - joint.lower)
    return round(min(max(0.0, joint.lower + clear), joint.upper - clear), 6)


def _damping(joint: Joint, drive: Drive) -> float:
    """effort / velocity: a drive at full effort moves the joint at its rated velocity (an electric motor's torque
    falls with speed so); the source's own damping where that is larger."""
    if drive.effort > 0 and drive.velocity > 0:
        return float(f"{max(joint.damping, drive.effort / drive.velocity):.4g}")
    return joint.damping


def _kp(joint: Joint) -> float:
    """A channel's servo: full effort 0.1 rad (5 mm) from its target (a channel is rated: spec_from_mimics checks)."""
    return round(joint.effort / STIFF_AT[joint.type], 3)


class _Dumper(yaml.SafeDumper):
    """Mappings as blocks, lists of numbers and names on one line."""


_Dumper.add_representer(
    list, lambda dumper, data: dumper.represent_sequence("tag:yaml.org,2002:seq", data, flow_style=True)
)


def _dump(value: object) -> str:
    return yaml.dump(value, Dumper=_Dumper, default_flow_style=False, sort_keys=False, width=110).rstrip("\n")


def _block(comment: str, value: dict) -> list[str]:
    return [*(f"# {line}".rstrip() for line in comment.splitlines()), _dump(value), ""]


def starter(source: Path, out: Path, given: dict[str, Path], quirks: dict[str, Any] | None = None) -> Starter:
    """The starter config for ``source`` written to ``out`` (paths in it are relative to ``out``'s folder);
    ``quirks``: ``joints.NAME`` settings (``--joint``) applied to the source and written into the config."""
    quirks = quirks or {}
    robot, mimics, packages = _read(source, given, quirks)
    config_dir = out.parent
    robot = _rate_leaders(robot, mimics, quirks)
    spec = spec_from_mimics(robot, mimics, source)
    coupled = {c.joint for c in spec.couplings} if spec else set()
    channels = [c.joint for c in spec.channels] if spec else []
    movable = [j for j in robot.joints if j.movable]
    if not movable:
        raise SvhdescError(f"{source}: robot {robot.name} has no movable joint: nothing to drive")
    arm = [j for j in movable if j.name not in coupled and j.name not in channels]
    joints_by = {j.name: j for j in robot.joints}
    lines = [
        f"# Starter config for {source.name} (robot {robot.name}), written by `svhdesc init`.",
        "# Build and check it with",
        f"#   svhdesc build --config {out.name} --out OUT && svhdesc validate --config {out.name} --out OUT",
        "# Every default the compiler applies to a third-party URDF is listed in docs/any-robot.md.",
        "",
    ]
    used = {name: packages[name] for name in _mesh_packages_of(robot, packages)}
    if used:
        written = {name: _written_path(path, config_dir) for name, path in sorted(used.items())}
        lines += _block(
            "the packages its meshes name (package://NAME/...), found beside the source", {"packages": written}
        )
    if spec is not None:
        lines += _channel_blocks(spec, robot, out)
    timestep = 0.001 if spec is not None else Simulation().timestep
    home = {j.name: _home(j) for j in movable if j.name not in coupled}
    hand_kp = max((_kp(joints_by[c]) for c in channels), default=0.0)
    drives = _drives(robot, arm, home, timestep, {c: hand_kp for c in channels})
    if arm:
        lines += _arm_blocks(arm, drives, timestep, _given(quirks))
    elif quirks:
        lines += _block("the quirks given to svhdesc init (--joint)", {"joints": _given(quirks)})
    lines += _masses(robot)
    lines += _block(
        "hull: one convex hull per mesh (fast); decompose: a CoACD convex decomposition (slow, cached)",
        {"collision": {"mode": "hull"}},
    )
    lines += _floor_block(robot, home)
    lines += _block(
        f"a pose clear of every joint's stops: 0 where it lies {HOME_CLEARANCE:.0%} of the range inside them, else\n"
        "the nearest such point, or the middle of a range without 0",
        {"keyframes": {"home": home}},
    )
    name = package_name(robot.name)
    renamed = f" (named {name}: a variant is a ROS package, and '{robot.name}' is no package name)"
    comment = "one variant: the source as it is" + (renamed if name != robot.name else "")
    lines += _block(comment, {"variants": {name: {"xacro": _written_path(source, config_dir)}}})
    coupling = None
    if spec is not None:
        coupling = _coupling_text(spec, source)
    return Starter("\n".join(lines), coupling)


FLOOR_GAP = 0.01  # m: how far below the robot at home the floor lies, where the robot reaches below its root


def _floor_block(robot: Robot, home: dict[str, float]) -> list[str]:
    """``scene.floor_z`` just below the robot at home where it reaches below its root (a quadruped or a humanoid
    fixed at its trunk: a floor at 0 would cut through its legs, and the simulation pushes them out of it); nothing
    where the robot stands on z = 0 (an arm on its base, within FLOOR_GAP), whose floor stays there."""
    frames = link_frames(robot, home)
    lowest = 0.0
    for link in robot.links:
        for geometry in link.collisions or link.visuals:
            try:
                shape = _source_shape(geometry)
            except MeshTooBig as exc:  # the build would refuse it: said before a config is written
                raise SvhdescError(f"link {link.name}: {exc}") from None
            except (SvhdescError, MeshError, OSError, ValueError):
                continue
            corners = np.asarray(shape.bounds, dtype=float)
            points = np.array([[x, y, z, 1.0] for x in corners[:, 0] for y in corners[:, 1] for z in corners[:, 2]])
            lowest = min(lowest, float(exact.matmul(points, frames[link.name].T)[:, 2].min()))
    if lowest >= -FLOOR_GAP:  # an arm's base mesh a hair below z = 0 keeps its floor there
        return []
    floor = float(f"{lowest - FLOOR_GAP:.3g}")
    return _block(
        f"the floor of the scene {FLOOR_GAP:g} m below the robot at home: it reaches {-lowest:.3g} m below its root",
        {"scene": {"floor_z": floor}},
    )


def _rate_leaders(robot: Robot, mimics: list, quirks: dict[str, Any]) -> Robot:
    """A <mimic> leader becomes a channel, which needs a rating: where the source gives none (Romeo's hands: effort
    and velocity 0), the guess an unrated arm joint gets (``drives.size_drive``), written as joints.NAME quirks
    (``quirks``, updated) and applied to ``robot``."""
    movable = {j.name: j for j in robot.joints if j.movable}
    follows = {m.joint: m.leader for m in mimics}
    leaders = set()
    for mimic in mimics:
        leader, seen = mimic.leader, {mimic.joint}
        while leader in follows and leader not in seen:
            seen.add(leader)
            leader = follows[leader]
        leaders.add(leader)
    unrated = [movable[n] for n in sorted(leaders) if n in movable and min(movable[n].effort, movable[n].velocity) <= 0]
    if not unrated:
        return robot
    home = {j.name: _home(j) for j in movable.values()}
    loads = worst_loads(robot, home, _masses_for_loads(robot), {j.name for j in unrated})
    rated = {}
    for joint in unrated:
        # the channel carries its followers too: their loads through the mimic's multiplier
        carried = [(joint.name, 1.0)] + [(m.joint, m.multiplier) for m in mimics if m.leader == joint.name]
        found = [(loads[n], f) for n, f in carried if n in loads]
        # the armature init gives the channel and each follower (ARMATURE) is inertia it moves too: Romeo's hands,
        # 13 followers of links weighing next to nothing, got 0.001 N m and never left home under 1.4 kg m^2
        armature = ARMATURE * math.fsum(f * f for _, f in carried)
        load = Load(
            math.fsum(abs(x.gravity * f) for x, f in found), math.fsum(x.inertia * f * f for x, f in found) + armature
        )
        drive = size_drive(joint.type, joint.effort, joint.velocity, load)
        rated[joint.name] = replace(joint, effort=drive.effort, velocity=drive.velocity)
        quirks[joint.name] = JointDynamics(effort=drive.effort, velocity=drive.velocity)
    return replace(robot, joints=tuple(rated.get(j.name, j) for j in robot.joints))


def worst_loads(
    robot: Robot, home: dict[str, float], masses: dict[str, Inertial], unrated: set[str]
) -> dict[str, Load]:
    """The loads at ``home``; for an ``unrated`` joint, whose drive is guessed from its load, the gravity load is
    the worst of home, the stops and GUESS_POSES poses spread over the ranges: at home an arm may hang down, load 0,
    and a drive sized there drops it as soon as it moves (a joint fell 2.5 rad in validate's gravity_hold)."""
    loads = joint_loads(robot, home, masses)
    if not unrated:
        return loads
    movable = [j for j in robot.joints if j.movable]
    spans = [(-math.pi, math.pi) if j.type == "continuous" else (j.lower, j.upper) for j in movable]
    worst = {name: abs(loads[name].gravity) for name in unrated if name in loads}
    # every joint at its lower stop, at its upper stop, then a Halton sequence over the ranges
    points = [np.zeros(len(movable)), np.ones(len(movable))]
    points += [halton(index, len(movable)) for index in range(1, GUESS_POSES + 1)]
    for point in points:
        pose = {j.name: lo + (hi - lo) * float(x) for j, (lo, hi), x in zip(movable, spans, point)}
        sampled = joint_loads(robot, pose, masses)
        for name in worst:
            worst[name] = max(worst[name], abs(sampled[name].gravity))
    return {name: replace(load, gravity=worst.get(name, load.gravity)) for name, load in loads.items()}


def _masses_for_loads(robot: Robot) -> dict[str, Inertial]:
    """Each link's inertial as the build will weigh it: the source's mass (its tensor only where valid), the guess
    for a link with geometry and no inertial."""
    found = {}
    for link in robot.links:
        inertial = link.inertial
        if inertial is None:
            if link.has_geometry:
                found[link.name] = Inertial(GUESSED_MASS, (0.0, 0.0, 0.0), (0.0,) * 6)  # type: ignore[arg-type]
            continue
        if inertial_problem(inertial.mass, inertial.inertia) is not None:
            inertial = _recomputed(link, inertial)
        found[link.name] = inertial
    return found


def _recomputed(link: Link, inertial: Inertial) -> Inertial:
    """An invalid source inertial as the build replaces it: the cylinder fitted to the link's geometry at its mass
    (``inertials.cylinder_inertial``); only the mass where the geometry cannot be read here."""
    if inertial.mass > 0 and link.has_geometry:
        try:
            shapes = [_source_shape(g) for g in (link.collisions or link.visuals)]
            return cylinder_inertial(trimesh.util.concatenate(shapes), inertial.mass)
        except (SvhdescError, MeshError, OSError, ValueError):
            pass
    return Inertial(max(inertial.mass, 0.0), inertial.com, (0.0,) * 6)  # type: ignore[arg-type]


def _source_shape(geometry: Geometry) -> trimesh.Trimesh:
    """A source geometry as the build's inertials stage sees it once its mesh is baked (scale applied)."""
    if geometry.kind != "mesh":
        return shape_of(geometry, Assets())
    mesh = load_mesh(Path(geometry.mesh or ""), geometry.scale)
    mesh.apply_transform(pose_matrix(geometry.origin))
    return mesh


def _drives(
    robot: Robot, arm: list[Joint], home: dict[str, float], timestep: float, channel_kp: dict[str, float]
) -> dict[str, Drive]:
    """Each arm joint's drive at ``home``, the kps held within what ``timestep`` integrates with the channels'."""
    masses = _masses_for_loads(robot)
    unrated = {j.name for j in arm if min(j.effort, j.velocity) <= 0}
    loads: dict[str, Load] = worst_loads(robot, home, masses, unrated)
    drives = {j.name: size_drive(j.type, j.effort, j.velocity, loads.get(j.name)) for j in arm}
    mobility = mobilities(robot, home, masses)
    fixed = sum(kp * mobility.get(name, 0.0) * timestep**2 for name, kp in channel_kp.items())
    damping = {j.name: _damping(j, drives[j.name]) for j in arm}
    return cap_stiffness(drives, mobility, timestep, damping, fixed)


def _given(quirks: dict[str, Any]) -> dict[str, dict[str, Any]]:
    """The quirks as the config writes them (``--joint``'s, and the renames of joints named like a link), the keys
    given, in the schema's order."""
    keys = ("rename", "type", "servo", "effort", "velocity", "lower", "upper", "mimic", "damping", "friction")
    return {name: {k: getattr(q, k) for k in keys if getattr(q, k) is not None} for name, q in quirks.items()}


def _arm_blocks(
    arm: list[Joint], drives: dict[str, Drive], timestep: float, given: dict[str, dict[str, Any]]
) -> list[str]:
    """The arm's servos, and the joints' damping, guessed ratings and the quirks given (``joints:``)."""
    capped = [j.name for j in arm if drives[j.name].capped]
    comment = (
        f"its independent movable joints: one position servo each, kp = effort / {STIFF_AT['revolute']} rad "
        f"({STIFF_AT['prismatic']} m)"
    )
    velocity = [name for name, entry in given.items() if entry.get("servo") == "velocity"]
    if velocity:
        comment += f"; a velocity servo on {', '.join(velocity)} (joints.NAME.servo: velocity; its kp unused)"
    if capped:
        comment += ";\n" + textwrap.fill(
            f"held lower where the timestep ({timestep:g} s) could not integrate it on the inertia behind the joint "
            f"(svhdesc/compiler/drives.py): {', '.join(capped)}",
            110,
        )
    lines = _block(
        comment, {"arm": {"enabled": True, "joints": [j.name for j in arm], "kp": [drives[j.name].kp for j in arm]}}
    )
    quirks: dict[str, dict[str, Any]] = {name: dict(entry) for name, entry in given.items()}
    for joint in arm:
        drive = drives[joint.name]
        entry = quirks.setdefault(joint.name, {})
        if drive.guessed:
            entry.update(effort=drive.effort, velocity=drive.velocity)
        elif drive.raised:
            entry.update(effort=drive.effort)
        # a velocity servo is the motor's speed control: it needs no damping for a far target (only the source's)
        damping = joint.damping if entry.get("servo") == "velocity" else _damping(joint, drive)
        if damping > 0 and "damping" not in entry:
            entry["damping"] = damping
    quirks = {name: entry for name, entry in quirks.items() if entry}
    if quirks:
        lines += _block(_joints_comment(arm, drives, given), {"joints": quirks})
    return lines


def _joints_comment(arm: list[Joint], drives: dict[str, Drive], given: dict[str, dict[str, Any]]) -> str:
    """What the ``joints:`` block holds and why: damping, guessed and raised ratings, renames."""
    guessed = [j.name for j in arm if drives[j.name].guessed]
    comment = (
        "the arm joints' damping (N m s/rad, N s/m): effort / velocity of the source's <limit>, so that a\n"
        "drive at full effort moves its joint at the rated velocity, as a motor's torque falls with speed (the\n"
        "source's <dynamics damping> where larger). Without it a light joint driven to a far target races into\n"
        "its stop."
    )
    if guessed:
        comment += "\n" + textwrap.fill(
            "The source rates no drive (effort or velocity 0) for: " + ", ".join(guessed) + ". Their effort and "
            "velocity are a GUESS (1.5 x the gravity load at home, at least 10 rad/s^2 on the inertia it moves; "
            "1 rad/s, 0.1 m/s): rate them",
            110,
        )
    renamed = {name: q["rename"] for name, q in given.items() if "rename" in q}
    if renamed:
        comment += "\n" + textwrap.fill(
            "Renamed, as SDFormat (Gazebo) refuses a joint named like a link: "
            + ", ".join(f"{old} -> {new}" for old, new in renamed.items()),
            110,
        )
    raised = [j for j in arm if drives[j.name].raised]
    if raised:
        comment += "\n" + textwrap.fill(
            "The source's effort cannot hold the robot at home for: "
            + ", ".join(f"{j.name} ({j.effort:g} -> {drives[j.name].effort:g})" for j in raised)
            + "; raised to 1.5 x the gravity load there (a deviation from the source: lower it, and pick a home the "
            "rated drives hold, to keep the rating)",
            110,
        )
    return comment


def _channel_blocks(spec: CouplingSpec, robot: Robot, out: Path) -> list[str]:
    """The coupling key, the channels' servo and the timestep the couplings need."""
    channels = [c.joint for c in spec.channels]
    joints = {j.name: j for j in robot.joints}
    lines: list[str] = []
    coupling_name = f"{out.stem}.coupling.yaml"
    lines += _block(
        f"its <mimic> tags as a coupling spec (channels: {', '.join(channels)}); edit it to add the real\n"
        "linkage's polynomials. Without this key the build reads the same spec from the <mimic> tags.",
        {"coupling": coupling_name},
    )
    lead = [joints[n] for n in channels]
    lines += _block(
        "the drives of the channels: one position servo each (kp = largest effort / "
        f"{STIFF_AT['prismatic']} m or {STIFF_AT['revolute']} rad). The armature (reflected rotor\n"
        "inertia) keeps light followers on their channel while the arm jerks (the Panda's fingers: 1.8 mm\n"
        "off without it, 0.8 mm with it, in validate's random targets)",
        {"hand": {"kp": max(_kp(j) for j in lead), "joint_armature": ARMATURE, "coupled_joint_armature": ARMATURE}},
    )
    lines += _block(
        "the couplings' equality constraints (solref 0.002 s) need a timestep <= 1 ms",
        {"simulation": {"timestep": 0.001}},
    )
    return lines


def _mesh_packages_of(robot: Robot, packages: dict[str, Path]) -> list[str]:
    """The packages some mesh of ``robot`` lies in."""
    files = [Path(g.mesh).resolve() for link in robot.links for g in (*link.visuals, *link.collisions) if g.mesh]
    return [name for name, root in packages.items() if any(f.is_relative_to(root.resolve()) for f in files)]


def _masses(robot: Robot) -> list[str]:
    masses = {link.name: link.inertial.mass for link in robot.links if link.inertial is not None}
    guessed = sorted(link.name for link in robot.links if link.inertial is None and link.has_geometry)
    total = sum(m for m in masses.values() if m > 0)
    comment = (
        f"masses: the source's inertials are kept (total {total:.4g} kg over {len(masses)} links); an invalid one is\n"
        "recomputed from the link's geometry, with a warning. mass.links sets a link's mass (kg)"
    )
    if not guessed:
        return [*(f"# {line}" for line in comment.splitlines()), "# mass: {links: {LINK: KG}}", ""]
    comment += (
        f";\nthese links have geometry but no inertial in the source: {GUESSED_MASS} kg each is a GUESS, weigh them"
    )
    return _block(comment, {"mass": {"links": {name: GUESSED_MASS for name in guessed}}})


def _coupling_text(spec: CouplingSpec, source: Path) -> str:
    channels = [
        {"name": c.name, "range": [c.lower, c.upper], "effort": c.effort, "velocity": c.velocity} for c in spec.channels
    ]
    couplings = [{"joint": c.joint, "follows": c.channel, "poly": list(c.coeffs)} for c in spec.couplings]
    header = (
        f"# The coupling spec of {source.name}, from its <mimic> tags (svhdesc init): each channel is one drive\n"
        "# (range in rad or m, effort, velocity from the leader joint's <limit>; the range narrowed to where every\n"
        "# follower stays inside its own limits); each coupled joint follows one channel as\n"
        "# joint = poly[0] + poly[1] * channel + poly[2] * channel^2 + ... (docs/any-robot.md).\n"
    )
    return header + _dump({"channels": channels, "couplings": couplings}) + "\n"
