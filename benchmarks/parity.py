"""What svhdesc makes of third-party robots beside MuJoCo's own URDF importer: a parity table.

    python benchmarks/parity.py                       # every robot below, writes docs/results/parity.md
    python benchmarks/parity.py --robots panda_pb,ur5 # some of them
    python benchmarks/parity.py --no-validate         # build only (faster)

The robots are those of the PyPI packages example-robot-data (6.0.0, its cmeel.prefix/share folder) and pybullet
(pybullet_data), read where pip put them, unedited. For each:

- MuJoCo's importer: ``mujoco.MjModel.from_xml_path`` on the URDF, the only help given being its mesh URIs
  resolved to absolute paths (as ROS, or pybullet for a URDF-relative ``package://``, would resolve them) and
  ``strippath="false"``; what it opens: actuators, equalities, total mass, and how far its joints fall in 2 s
  (it makes no actuators, so nothing holds them).
- svhdesc: ``svhdesc init URDF --out CONFIG`` (a starter config, unedited), ``svhdesc build``, ``svhdesc validate``
  (every check; those that do not apply are skipped); the built MJCF's actuators, equalities and total mass, and
  validate's ``gravity_hold`` drift at ``home`` (servos holding the keyframe for 2 s after 0.5 s of settling).

Every step that fails is reported with its first error line; nothing is retried or patched. The URDF's mass is the
sum of its ``<inertial><mass>`` values. Not a test: each robot takes tens of seconds to a few minutes.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))
os.environ.setdefault("WARP_CACHE_PATH", str(REPO / ".cache" / "warp"))

import mujoco  # noqa: E402
import numpy as np  # noqa: E402
from lxml import etree  # noqa: E402

sys.path.insert(0, str(REPO / "benchmarks"))
from results import write  # noqa: E402

SITE = Path(np.__file__).resolve().parents[1]  # site-packages, where pip put the robots' wheels
ERD = SITE / "cmeel.prefix" / "share" / "example-robot-data"
PYBULLET = SITE / "pybullet_data"
ROBOTS: dict[str, Path] = {
    "ur5": ERD / "robots/ur_description/urdf/ur5_robot.urdf",
    "ur10": ERD / "robots/ur_description/urdf/ur10_robot.urdf",
    "panda": ERD / "robots/panda_description/urdf/panda.urdf",
    "kinova": ERD / "robots/kinova_description/robots/kinova.urdf",
    "allegro": ERD / "robots/allegro_hand_description/urdf/allegro_right_hand.urdf",
    "talos": ERD / "robots/talos_data/robots/talos_reduced.urdf",
    "z1": ERD / "robots/z1_description/urdf/z1.urdf",
    "so100": ERD / "robots/so_arm_description/urdf/so100.urdf",
    "double_pendulum": ERD / "robots/double_pendulum_description/urdf/double_pendulum.urdf",
    "panda_pb": PYBULLET / "franka_panda/panda.urdf",
    "kuka_iiwa_pb": PYBULLET / "kuka_iiwa/model.urdf",
    "xarm6_pb": PYBULLET / "xarm/xarm6_robot.urdf",
}
OUT = REPO / "docs" / "results" / "parity.md"
TITLE = "Parity: svhdesc beside MuJoCo's URDF importer"
STEP_TIMEOUT = 900  # s per svhdesc command
DROP = 2.0  # s the importer's model is left to fall


def portable(text: str) -> str:
    """Paths under site-packages written without the machine's prefix: the table reads the same anywhere."""
    return text.replace(str(SITE) + os.sep, "").replace(str(REPO) + os.sep, "")


def first_line(text: str) -> str:
    text = portable(text)
    lines = [line.strip() for line in text.strip().splitlines() if line.strip()]
    errors = [line for line in lines if line.startswith("error:")]
    return (errors or lines or ["(no output)"])[-1][:160]


def urdf_mass(urdf: Path) -> float:
    root = etree.parse(str(urdf)).getroot()
    return sum(float(m.get("value", "0")) for m in root.iterfind("link/inertial/mass"))


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
    tree = etree.parse(str(urdf))
    for mesh in tree.iter("mesh"):
        path = resolve_uri(mesh.get("filename", ""), urdf)
        if path is not None:
            mesh.set("filename", str(path))
    root = tree.getroot()
    extension = root.find("mujoco")
    if extension is None:
        extension = etree.SubElement(root, "mujoco")
    compiler = extension.find("compiler")
    if compiler is None:
        compiler = etree.SubElement(extension, "compiler")
    compiler.set("strippath", "false")
    path = folder / urdf.name
    tree.write(str(path))
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


def svhdesc_side(urdf: Path, folder: Path, validate: bool) -> dict[str, Any]:
    config, out = folder / "robot.yaml", folder / "out"
    result = cli("init", str(urdf), "--out", str(config))
    if result.returncode != 0:
        return {"builds": False, "error": f"init: {first_line(result.stderr + result.stdout)}"}
    result = cli("build", "--config", str(config), "--out", str(out))
    if result.returncode != 0:
        return {"builds": False, "error": f"build: {first_line(result.stderr + result.stdout)}"}
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
        report = folder / "report.json"
        result = cli("validate", "--config", str(config), "--out", str(out), "--json", str(report))
        checks = json.loads(report.read_text())["variants"][0]["checks"] if report.is_file() else []
        failed = [c["name"] for c in checks if c["status"] not in ("pass", "skipped")]
        side["failures"] = {
            c["name"]: portable(c["detail"])[:240] for c in checks if c["status"] not in ("pass", "skipped")
        }
        side["validate"] = (
            "pass" if result.returncode == 0 else f"fail: {', '.join(failed) or first_line(result.stderr)}"
        )
        hold = next((c for c in checks if c["name"] == "gravity_hold"), None)
        drift = (hold or {}).get("data", {}).get("keyframes", {}).get("home", {}).get("drift")
        side["hold_mrad"] = None if drift is None else float(drift) * 1e3
    return side


def measure(name: str, urdf: Path, validate: bool) -> Row:
    started = time.perf_counter()
    row = Row(name, str(urdf.relative_to(SITE)), urdf_mass(urdf))
    with tempfile.TemporaryDirectory(prefix=f"parity-{name}-") as tmp:
        row.mujoco = mujoco_side(urdf, Path(tmp))
        row.svhdesc = svhdesc_side(urdf, Path(tmp), validate)
        for side in (row.mujoco, row.svhdesc):  # the temporary folder's name is random
            if "error" in side:
                side["error"] = side["error"].replace(tmp, "<tmp>")
    row.seconds = time.perf_counter() - started
    return row


def mass_cell(mass: float | None, reference: float) -> str:
    if mass is None:
        return "-"
    return f"{mass:.3f} ({100 * (mass - reference) / reference:+.1f} %)" if reference > 0 else f"{mass:.3f}"


def render(rows: list[Row], validate: bool) -> list[str]:
    header = "| robot | URDF mass kg | MuJoCo importer: opens, act., eq., mass kg, falls in 2 s | "
    header += "svhdesc: builds | validate | act. | eq. | mass kg | hold drift at home |"
    lines = [
        f"mujoco {mujoco.__version__}; robots from example-robot-data and "
        "pybullet_data as pip installed them, unedited. MuJoCo's importer got absolute mesh paths and "
        "`strippath=false`; svhdesc got the config `svhdesc init` wrote, unedited. Mass deviations are against "
        "the URDF's sum of `<inertial><mass>`.",
        "",
        header,
        "|" + "---|" * 10,
    ]
    for r in rows:
        m, s = r.mujoco, r.svhdesc
        importer = (
            f"yes, {m['actuators']}, {m['equalities']}, {mass_cell(m['mass'], r.urdf_mass)}, {m['drop_rad']:.3g} rad"
            if m.get("opens")
            else f"no: {m.get('error', '')}"
        )
        builds = f"yes ({s['warnings']} warnings)" if s.get("builds") else f"no: {s.get('error', '')}"
        hold = s.get("hold_mrad")
        cells = [
            r.robot,
            f"{r.urdf_mass:.3f}",
            importer,
            builds,
            s.get("validate", "not run" if s.get("builds") and not validate else "-"),
            str(s.get("actuators", "-")),
            str(s.get("equalities", "-")),
            mass_cell(s.get("mass"), r.urdf_mass),
            "-" if hold is None else f"{hold:.3g} mrad",
        ]
        lines.append("| " + " | ".join(c.replace("|", "/") for c in cells) + " |")
    failures = [(r.robot, name, text) for r in rows for name, text in r.svhdesc.get("failures", {}).items()]
    if failures:
        lines += ["", "What failed (validate's detail, shortened):", ""]
        lines += [f"- {robot} `{name}`: {text}" for robot, name, text in failures]
    lines += ["", "Sources (under site-packages):", ""]
    lines += [f"- {r.robot}: `{r.source}` ({r.seconds:.0f} s)" for r in rows]
    opened = sum(1 for r in rows if r.mujoco.get("opens"))
    built = sum(1 for r in rows if r.svhdesc.get("builds"))
    passed = sum(1 for r in rows if r.svhdesc.get("validate") == "pass")
    lines += ["", f"MuJoCo's importer opened {opened} of {len(rows)}; svhdesc built {built}, validate passed {passed}."]
    return lines


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--robots", default="", help="comma-separated names (default: all): " + ", ".join(ROBOTS))
    parser.add_argument("--no-validate", action="store_true", help="build only")
    parser.add_argument("--out", type=Path, default=OUT)
    args = parser.parse_args()
    names = [n for n in args.robots.split(",") if n] or list(ROBOTS)
    unknown = [n for n in names if n not in ROBOTS]
    if unknown:
        parser.error(f"unknown robots: {', '.join(unknown)}")
    rows = []
    for name in names:
        if not ROBOTS[name].is_file():
            print(f"{name}: {ROBOTS[name]} not installed (pip install example-robot-data==6.0.0 pybullet)")
            continue
        row = measure(name, ROBOTS[name], not args.no_validate)
        print(f"{name}: importer {row.mujoco} svhdesc {row.svhdesc} ({row.seconds:.0f} s)", flush=True)
        rows.append(row)
        # After each robot: a long run leaves what it did.
        write(args.out.stem, TITLE, render(rows, not args.no_validate), args.out.parent)
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
