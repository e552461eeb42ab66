"""What svhdesc makes of every fixed-base robot of two wheels, beside MuJoCo's own URDF importer: a parity table.

    python benchmarks/parity.py                          # the whole population, writes docs/results/parity.md
    python benchmarks/parity.py --robots erd:ur_description/ur5_robot,pb:cartpole   # rerun some, keep the rest
    python benchmarks/parity.py --list                   # the population and what was left out, nothing run

The population is enumerated from the installed wheels, not picked: every ``*.urdf`` under example-robot-data's
share folder (``cmeel.prefix/share/example-robot-data/robots``) and under ``pybullet_data``, read where pip put
them. A file is a **robot** when it has at least one movable joint (revolute, continuous, prismatic): pybullet's
objects (cubes, tables, the generated ``random_urdfs``) are not. A robot is **fixed-base** unless its wheel
declares its base free: a ``floating`` or ``planar`` joint in the URDF, or a ``<virtual_joint>`` of type
``floating`` or ``planar`` in an SRDF of its package with the URDF's name (example-robot-data ships one for most
legged robots and for the PR2). A robot that declares nothing is built, as MuJoCo's importer, pinocchio without a
root joint and pybullet's ``useFixedBase`` load it, with its root link fixed to the world (a humanoid on a stand,
a mobile manipulator with its base parked). Files that are not well-formed XML are read leniently for the
enumeration only, so a robot in a broken file is counted and its fault reported.

For each fixed-base robot:

- MuJoCo's importer: ``mujoco.MjModel.from_xml_path`` on the URDF, the only help given being its mesh URIs
  resolved to absolute paths (as ROS, or pybullet for a URDF-relative ``package://``, would resolve them) and
  ``strippath="false"``; what it opens: actuators, equalities, total mass, and how far its joints fall in 2 s
  (it makes no actuators, so nothing holds them).
- svhdesc: ``svhdesc init URDF --out CONFIG`` (a starter config, unedited), ``svhdesc build``, ``svhdesc validate``
  (every check; those that do not apply are skipped); the built MJCF's actuators, equalities and total mass, and
  validate's ``gravity_hold`` drift at ``home``.

Every step that fails is reported with its error line; nothing is retried or patched. The URDF's mass is the sum of
its ``<inertial><mass>`` values. Each robot's row is kept in docs/results/parity.json, so a run of some robots
(``--robots``) rewrites the page with the others' last rows; the page says which population it covers, and the
README's parity block (the page's first table: the summary) and benchmarks/README.md are refilled from it, as
benchmarks/collect.py does. Not a test: each robot takes
tens of seconds to minutes.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from concurrent.futures import ThreadPoolExecutor, as_completed
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))
os.environ.setdefault("WARP_CACHE_PATH", str(REPO / ".cache" / "warp"))

import mujoco  # noqa: E402
import numpy as np  # noqa: E402
from lxml import etree  # noqa: E402

sys.path.insert(0, str(REPO / "benchmarks"))
from collect import PROJECT_README, README, fill_blocks  # noqa: E402
from collect import render as collected  # noqa: E402
from results import write  # noqa: E402

SITE = Path(np.__file__).resolve().parents[1]  # site-packages, where pip put the robots' wheels
ERD = SITE / "cmeel.prefix" / "share" / "example-robot-data"
PYBULLET = SITE / "pybullet_data"
WHEELS = {"erd": ERD / "robots", "pb": PYBULLET}  # name prefix -> folder enumerated
MOVABLE = {"revolute", "continuous", "prismatic"}
FREE = {"floating", "planar"}
OUT = REPO / "docs" / "results" / "parity.md"
TITLE = "Parity: svhdesc beside MuJoCo's URDF importer, every fixed-base robot of two wheels"
STEP_TIMEOUT = 900  # s per svhdesc command
DROP = 2.0  # s the importer's model is left to fall


@dataclass(frozen=True)
class Candidate:
    """A URDF of a wheel: its name in the table, its file, its movable joints and why it is not fixed-base."""

    name: str
    path: Path
    movable: int
    free: str  # "" for a fixed-base robot, else what declares its base free


def _lenient_root(path: Path) -> etree._Element | None:
    """The file's root element, read as leniently as lxml can (a broken file's robot is still counted)."""
    parser = etree.XMLParser(recover=True, remove_comments=True, resolve_entities=False, no_network=True)
    try:
        text = path.read_bytes()
        root = etree.fromstring(
            text.lstrip().split(b"?>", 1)[1] if text.lstrip().startswith(b"<?xml") else text, parser
        )
    except (OSError, etree.XMLSyntaxError, IndexError):
        return None
    return root


def _srdf_free(path: Path, package: Path) -> str:
    """The free virtual joint an SRDF of ``package`` named as ``path`` declares, or ""."""
    for srdf in sorted(package.rglob(f"{path.stem}.srdf")):
        root = _lenient_root(srdf)
        for joint in root.iter("virtual_joint") if root is not None else ():
            if joint.get("type") in FREE:
                return f"{portable(str(srdf))}: virtual_joint {joint.get('name')} is {joint.get('type')}"
    return ""


def candidate(wheel: str, folder: Path, path: Path) -> Candidate | None:
    """The robot in ``path``, or None for a file without a movable joint (an object, not a robot)."""
    root = _lenient_root(path)
    if root is None or root.tag != "robot":
        return None
    types = [j.get("type") for j in root.iter("joint") if j.getparent() is root]
    movable = sum(t in MOVABLE for t in types)
    if not movable:
        return None
    relative = path.relative_to(folder)
    name = f"{wheel}:{relative.parts[0]}/{path.stem}" if wheel == "erd" else f"{wheel}:{relative.with_suffix('')}"
    free = next((f"its joint of type {t}" for t in types if t in FREE), "")
    if not free and wheel == "erd":
        free = _srdf_free(path, folder / relative.parts[0])
    return Candidate(name, path, movable, free)


def population() -> list[Candidate]:
    """Every robot of the two wheels, fixed-base or not, in name order."""
    found = []
    for wheel, folder in WHEELS.items():
        for path in sorted(folder.rglob("*.urdf")):
            robot = candidate(wheel, folder, path)
            if robot is not None:
                found.append(robot)
    return sorted(found, key=lambda c: c.name)


def fixed_base() -> dict[str, Candidate]:
    """The population the table covers."""
    return {c.name: c for c in population() if not c.free}


def portable(text: str) -> str:
    """Paths under site-packages written without the machine's prefix: the table reads the same anywhere."""
    return text.replace(str(SITE) + os.sep, "").replace(str(REPO) + os.sep, "")


def error_line(text: str) -> str:
    text = portable(text)
    lines = [line.strip() for line in text.strip().splitlines() if line.strip()]
    errors = [line for line in lines if line.startswith("error:")]
    return (errors or lines or ["(no output)"])[-1][:400]


def urdf_mass(urdf: Path) -> float:
    root = _lenient_root(urdf)
    masses = root.iterfind("link/inertial/mass") if root is not None else ()
    total = 0.0
    for mass in masses:
        try:
            total += float(mass.get("value", "0"))
        except ValueError:
            pass
    return total


def resolve_uri(uri: str, urdf: Path) -> Path | None:
    """A mesh URI as ROS would find it (example-robot-data is the package of its share folder), or pybullet (a
    ``package://`` or relative path beside the URDF)."""
    if uri.startswith("package://"):
        package, _, rest = uri.removeprefix("package://").lstrip("/").partition("/")
        candidates = [ERD / rest if package == "example-robot-data" else None, urdf.parent / package / rest]
        candidates += [urdf.parent.parent / package / rest, ERD / "robots" / package / rest]
    elif uri.startswith("file://"):
        candidates = [Path(uri.removeprefix("file://"))]
    else:
        candidates = [urdf.parent / uri]
    return next((p.resolve() for p in candidates if p is not None and p.is_file()), None)


def importer_urdf(urdf: Path, folder: Path) -> Path:
    """The URDF with absolute mesh paths and strippath off: what MuJoCo's importer needs to find meshes at all."""
    root = _lenient_root(urdf)
    if root is None:
        raise ValueError("not XML")
    for mesh in root.iter("mesh"):
        path = resolve_uri(mesh.get("filename", ""), urdf)
        if path is not None:
            mesh.set("filename", str(path))
    extension = root.find("mujoco")
    if extension is None:
        extension = etree.SubElement(root, "mujoco")
    compiler = extension.find("compiler")
    if compiler is None:
        compiler = etree.SubElement(extension, "compiler")
    compiler.set("strippath", "false")
    path = folder / urdf.name
    etree.ElementTree(root).write(str(path))
    return path


def drop(model: Any) -> float:
    """Largest hinge/slide excursion from qpos0 in DROP s, nothing driving the joints."""
    from svhdesc.model import scalar_joints

    data = mujoco.MjData(model)
    adr = np.array([model.jnt_qposadr[j] for j in scalar_joints(model)], dtype=int)
    start, worst = data.qpos[adr].copy(), 0.0
    for _ in range(int(round(DROP / model.opt.timestep))):
        mujoco.mj_step(model, data)
        if not np.isfinite(data.qpos).all():
            return float("inf")
        worst = max(worst, float(np.abs(data.qpos[adr] - start).max(initial=0.0)))
    return worst


@dataclass
class Row:
    robot: str
    source: str
    urdf_mass: float
    mujoco: dict[str, Any] = field(default_factory=dict)
    svhdesc: dict[str, Any] = field(default_factory=dict)
    seconds: float = 0.0


def mujoco_side(urdf: Path, folder: Path) -> dict[str, Any]:
    try:
        model = mujoco.MjModel.from_xml_path(str(importer_urdf(urdf, folder)))
    except (ValueError, OSError) as exc:
        return {"opens": False, "error": portable(" ".join(str(exc).strip().splitlines()[:2]))[:160]}
    return {
        "opens": True,
        "nq": int(model.nq),
        "actuators": int(model.nu),
        "equalities": int(model.neq),
        "mass": float(model.body_mass.sum()),
        "drop_rad": drop(model),
    }


def cli(*args: str) -> subprocess.CompletedProcess[str]:
    env = dict(os.environ, PYTHONPATH=str(REPO) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    command = [sys.executable, "-m", "svhdesc.cli", *args]
    try:
        return subprocess.run(command, capture_output=True, text=True, timeout=STEP_TIMEOUT, env=env, check=False)
    except subprocess.TimeoutExpired:
        return subprocess.CompletedProcess(command, 124, "", f"error: timed out after {STEP_TIMEOUT} s")


def validate_side(config: Path, out: Path, folder: Path) -> dict[str, Any]:
    report = folder / "report.json"
    result = cli("validate", "--config", str(config), "--out", str(out), "--json", str(report))
    checks = json.loads(report.read_text())["variants"][0]["checks"] if report.is_file() else []
    failed = {c["name"]: portable(c["detail"])[:240] for c in checks if c["status"] not in ("pass", "skipped")}
    hold = next((c for c in checks if c["name"] == "gravity_hold"), None)
    drift = (hold or {}).get("data", {}).get("keyframes", {}).get("home", {}).get("drift")
    verdict = "pass" if result.returncode == 0 else f"fail: {', '.join(failed) or error_line(result.stderr)}"
    return {"validate": verdict, "failures": failed, "hold_mrad": None if drift is None else float(drift) * 1e3}


def svhdesc_side(urdf: Path, folder: Path, validate: bool) -> dict[str, Any]:
    config, out = folder / "robot.yaml", folder / "out"
    result = cli("init", str(urdf), "--out", str(config))
    if result.returncode != 0:
        return {"builds": False, "stage": "init", "error": error_line(result.stderr + result.stdout)}
    result = cli("build", "--config", str(config), "--out", str(out))
    if result.returncode != 0:
        return {"builds": False, "stage": "build", "error": error_line(result.stderr + result.stdout)}
    variants = [d for d in sorted(out.iterdir()) if (d / f"{d.name}.xml").is_file()]
    model = mujoco.MjModel.from_xml_path(str(variants[0] / f"{variants[0].name}.xml"))
    side: dict[str, Any] = {
        "builds": True,
        "warnings": sum(line.startswith("warning:") for line in result.stderr.splitlines()),
        "actuators": int(model.nu),
        "equalities": int(model.neq),
        "mass": float(model.body_mass.sum()),
    }
    if validate:
        side.update(validate_side(config, out, folder))
    return side


def measure(robot: Candidate, validate: bool) -> Row:
    started = time.perf_counter()
    row = Row(robot.name, str(robot.path.relative_to(SITE)), urdf_mass(robot.path))
    with tempfile.TemporaryDirectory(prefix="parity-") as tmp:
        row.mujoco = mujoco_side(robot.path, Path(tmp))
        row.svhdesc = svhdesc_side(robot.path, Path(tmp), validate)
        for side in (row.mujoco, row.svhdesc):  # the temporary folder's name is random
            if "error" in side:
                side["error"] = side["error"].replace(tmp, "<tmp>")
    row.seconds = time.perf_counter() - started
    return row


def mass_cell(mass: float | None, reference: float) -> str:
    if mass is None:
        return "-"
    return f"{mass:.3f} ({100 * (mass - reference) / reference:+.1f} %)" if reference > 0 else f"{mass:.3f}"


def outcome(row: Row | None) -> str:
    """passed | refused (init or build stopped with one error line) | failed (built, validate failed) | not run"""
    if row is None:
        return "not run"
    side = row.svhdesc
    if not side.get("builds"):
        return "refused"
    return {"pass": "passed", None: "built"}.get(side.get("validate"), "failed")


def summary(rows: dict[str, Row | None]) -> list[str]:
    """The first table: how the population fared, by wheel."""
    wheels = sorted({name.split(":")[0] for name in rows})
    kinds = ["passed", "refused", "failed", "built", "not run"]
    counts = {w: {k: 0 for k in kinds} for w in wheels}
    for name, row in rows.items():
        counts[name.split(":")[0]][outcome(row)] += 1
    lines = [
        "| wheel | fixed-base robots | init -> build -> validate passed | refused with one error line | "
        "built, validate failed | built, not validated | not run |",
        "|---|---|---|---|---|---|---|",
    ]
    labels = {"erd": "example-robot-data", "pb": "pybullet_data"}
    for wheel in wheels:
        c = counts[wheel]
        lines.append(
            f"| {labels.get(wheel, wheel)} | {sum(c.values())} | " + " | ".join(str(c[k]) for k in kinds) + " |"
        )
    total = {k: sum(counts[w][k] for w in wheels) for k in kinds}
    lines.append(f"| both | {sum(total.values())} | " + " | ".join(str(total[k]) for k in kinds) + " |")
    return lines


def row_cells(name: str, r: Row | None) -> list[str]:
    if r is None:
        return [name, "-", "not run", "-", "-", "-", "-", "-", "-"]
    m, s = r.mujoco, r.svhdesc
    importer = (
        f"yes, {m['actuators']}, {m['equalities']}, {mass_cell(m['mass'], r.urdf_mass)}, {m['drop_rad']:.3g} rad"
        if m.get("opens")
        else f"no: {m.get('error', '')}"
    )
    builds = f"yes ({s['warnings']} warnings)" if s.get("builds") else f"no: {s.get('stage')}: {s.get('error', '')}"
    hold = s.get("hold_mrad")
    return [
        name,
        f"{r.urdf_mass:.3f}",
        importer,
        builds,
        s.get("validate", "not run" if s.get("builds") else "-"),
        str(s.get("actuators", "-")),
        str(s.get("equalities", "-")),
        mass_cell(s.get("mass"), r.urdf_mass),
        "-" if hold is None else f"{hold:.3g} mrad",
    ]


def render(rows: dict[str, Row | None], left_out: list[Candidate]) -> list[str]:
    lines = [
        f"mujoco {mujoco.__version__}; every fixed-base robot of example-robot-data and pybullet_data as pip "
        "installed them, unedited (how the population is enumerated: the docstring of benchmarks/parity.py). "
        "MuJoCo's importer got absolute mesh paths and `strippath=false`; svhdesc got the config `svhdesc init` "
        "wrote, unedited. Mass deviations are against the URDF's sum of `<inertial><mass>`.",
        "",
        *summary(rows),
        "",
        "| robot | URDF mass kg | MuJoCo importer: opens, act., eq., mass kg, falls in 2 s | svhdesc: builds | "
        "validate | act. | eq. | mass kg | hold drift at home |",
        "|" + "---|" * 9,
    ]
    for name, r in rows.items():
        lines.append("| " + " | ".join(c.replace("|", "/") for c in row_cells(name, r)) + " |")
    failures = [(n, c, t) for n, r in rows.items() if r for c, t in r.svhdesc.get("failures", {}).items()]
    if failures:
        lines += ["", "What failed (validate's detail, shortened):", ""]
        lines += [f"- {robot} `{name}`: {text}" for robot, name, text in failures]
    lines += ["", "Sources (under site-packages) and each robot's time:", ""]
    lines += [f"- {n}: `{r.source}` ({r.seconds:.0f} s)" for n, r in rows.items() if r]
    lines += ["", f"Robots of the two wheels left out as not fixed-base ({len(left_out)}):", ""]
    lines += [f"- {c.name}: {c.free}" for c in left_out]
    return lines


RESULTS_JSON = OUT.with_suffix(".json")


def load_rows(path: Path) -> dict[str, Row]:
    if not path.is_file():
        return {}
    return {name: Row(**row) for name, row in json.loads(path.read_text()).items()}


def save(rows: dict[str, Row | None], left_out: list[Candidate], out: Path) -> None:
    """The page, the rows behind it, and the README's parity block refilled from the page."""
    kept = {name: asdict(row) for name, row in rows.items() if row is not None}
    out.with_suffix(".json").write_text(json.dumps(kept, indent=1, sort_keys=True) + "\n")
    write(out.stem, TITLE, render(rows, left_out), out.parent)
    if out == OUT:  # what benchmarks/collect.py makes of the pages: the README's parity block, benchmarks/README.md
        PROJECT_README.write_text(fill_blocks(PROJECT_README.read_text(encoding="utf-8")), encoding="utf-8")
        README.write_text(collected())


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--robots", default="", help="comma-separated names (default: the whole population)")
    parser.add_argument("--missing", action="store_true", help="only the robots without a row yet")
    parser.add_argument("--no-validate", action="store_true", help="build only")
    parser.add_argument("--list", action="store_true", help="print the population, run nothing")
    parser.add_argument("--jobs", type=int, default=1, help="robots measured at once (default 1)")
    parser.add_argument("--out", type=Path, default=OUT)
    args = parser.parse_args()
    robots = population()
    fixed = {c.name: c for c in robots if not c.free}
    left_out = [c for c in robots if c.free]
    if args.list:
        for c in robots:
            print(f"{c.name}\t{c.movable} movable\t{c.free or 'fixed-base'}\t{portable(str(c.path))}")
        return
    names = [n for n in args.robots.split(",") if n] or list(fixed)
    unknown = [n for n in names if n not in fixed]
    if unknown:
        parser.error(f"not in the fixed-base population: {', '.join(unknown)} (see --list)")
    stored = load_rows(args.out.with_suffix(".json"))
    rows: dict[str, Row | None] = {name: stored.get(name) for name in fixed}
    if args.missing:
        names = [n for n in names if rows[n] is None]
    order = sorted(names, key=lambda n: (fixed[n].movable, n))  # the small ones first: early rows
    with ThreadPoolExecutor(max_workers=max(1, args.jobs)) as pool:  # each robot runs in its own processes
        futures = {pool.submit(measure, fixed[name], not args.no_validate): name for name in order}
        for future in as_completed(futures):
            row = future.result()
            print(f"{row.robot}: {outcome(row)} {row.svhdesc} ({row.seconds:.0f} s)", flush=True)
            rows[row.robot] = row
            save(rows, left_out, args.out)  # after each robot: a long run leaves what it did
    save(rows, left_out, args.out)
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
