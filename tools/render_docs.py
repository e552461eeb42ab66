"""Regenerate every rendered picture under docs/, with fixed file names, from the current models.

    python tools/render_docs.py [--only variants,arms,grasps,pick_and_place] [--out docs] [--arms-dir DIR]

- variants: docs/<variant>.png for each built variant under generated/ (640x480);
- arms: docs/<example>.png for the mount examples (examples/<example>/<example>.yaml), built first into
  --arms-dir (default a temporary folder; a folder that already holds the build is reused);
- grasps: docs/grasp_<name>.png, svh_right closing each configured grasp on its object (480x480), as
  `svhdesc render svh_right --grasp NAME` draws it;
- pick_and_place: docs/pick_and_place_<moment>.png and docs/pick_and_place_hand.png from the saved run
  docs/results/pick_and_place.json, which `python examples/pick_and_place.py --json docs/results/pick_and_place.json`
  writes (it needs a ROS master and the simulation: see docs/pick_and_place.md); drawing the pictures needs neither;
- wireloop: docs/wireloop_mujoco.png, the UR5 + SVH after the learned wire-loop plan (`svhdesc wireloop train`
  with its defaults, then `svhdesc wireloop mujoco --path test`: the test path, final pose; about half a minute);
- learning: docs/learn_<task>.png, one episode (seed 1, the main model) of each trained policy that
  benchmarks/learn_bench.py kept beside its results page (docs/results/learn_<task>.onnx), as
  `svhdesc play TASK --checkpoint docs/results/learn_<task>.onnx --out docs/learn_<task>.png` draws it.

Every picture goes through svhdesc.validate.render (the light studio of svhdesc.offscreen).
"""

from __future__ import annotations

import argparse
import importlib.util
import json
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

import svhdesc  # noqa: E402
from svhdesc.validate.grasps import render_grasp  # noqa: E402
from svhdesc.validate.render import render  # noqa: E402

# (azimuth, elevation) per picture, degrees: each variant from where its palm and thumb show.
VIEWS = {
    "svh_right": (210.0, -20.0),
    "svh_left": (150.0, -20.0),
    "ur5_svh_right": (150.0, -20.0),
    "panda_svh": (150.0, -20.0),
    "ur10_svh": (150.0, -20.0),
    "kinova_svh": (150.0, -20.0),
}
ARMS = ("panda_svh", "ur10_svh", "kinova_svh")
GRASP_VARIANT = "svh_right"
PICK_AND_PLACE = REPO / "docs" / "results" / "pick_and_place.json"
PARTS = ("variants", "arms", "grasps", "pick_and_place", "wireloop", "learning")


def draw_variants(out: Path) -> list[Path]:
    written = []
    for name in svhdesc.variants():
        path = out / f"{name}.png"
        render(svhdesc.get(name).directory, path, None, (640, 480), VIEWS.get(name))
        written.append(path)
    return written


def draw_arms(out: Path, arms_dir: Path) -> list[Path]:
    written = []
    for name in ARMS:
        built = arms_dir / name / name
        if not (built / f"{name}.xml").is_file():
            config = REPO / "examples" / name / f"{name}.yaml"
            command = [
                sys.executable,
                "-m",
                "svhdesc.cli",
                "build",
                "--config",
                str(config),
                "--out",
                str(arms_dir / name),
            ]
            subprocess.run(command, check=True, cwd=REPO)
        path = out / f"{name}.png"
        render(built, path, None, (640, 480), VIEWS.get(name))
        written.append(path)
    return written


def draw_grasps(out: Path) -> list[Path]:
    directory = svhdesc.get(GRASP_VARIANT).directory
    configuration = svhdesc.get(GRASP_VARIANT).configuration()
    names = list(configuration.settings.grasps) if configuration is not None else []
    written = []
    for name in names:
        path = out / f"grasp_{name}.png"
        render_grasp(directory, name, path, (480, 480))
        written.append(path)
    return written


def draw_pick_and_place(out: Path, report: Path) -> list[Path]:
    if not report.is_file():
        raise SystemExit(f"error: {report} is missing: run examples/pick_and_place.py --json {report} first")
    spec = importlib.util.spec_from_file_location("pick_and_place", REPO / "examples" / "pick_and_place.py")
    assert spec is not None and spec.loader is not None
    example = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(example)
    return example.render_moments(json.loads(report.read_text())["moments"], out)


def draw_wireloop(out: Path, scratch: Path) -> list[Path]:
    cli = [sys.executable, "-m", "svhdesc.cli", "wireloop"]
    subprocess.run([*cli, "train", "--out", str(scratch)], check=True, cwd=REPO, stdout=subprocess.DEVNULL)
    policy = scratch / "q_table.json"
    command = [*cli, "mujoco", "--policy", str(policy), "--path", "test", "--out", str(scratch)]
    subprocess.run(command, check=True, cwd=REPO)
    path = out / "wireloop_mujoco.png"
    shutil.copyfile(scratch / "mujoco.png", path)
    return [path]


def draw_learning(out: Path) -> list[Path]:
    written = []
    for policy in sorted((REPO / "docs" / "results").glob("learn_*.onnx")):
        task = policy.stem.removeprefix("learn_")
        if "_gpu" in task:
            continue  # the CPU run's picture; a GPU's policy is the same task's
        path = out / f"learn_{task}.png"
        command = [sys.executable, "-m", "svhdesc.cli", "play", task, "--checkpoint", str(policy), "--episodes", "0"]
        subprocess.run([*command, "--out", str(path), "--frames", "5"], check=True, cwd=REPO)
        written.append(path)
    return written


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--only", default=",".join(PARTS), help=f"comma-separated parts ({', '.join(PARTS)})")
    parser.add_argument("--out", type=Path, default=REPO / "docs", help="folder the pictures go to")
    parser.add_argument("--arms-dir", type=Path, default=None, help="build the arm examples here (kept)")
    parser.add_argument("--pick-and-place", type=Path, default=PICK_AND_PLACE, help="saved pick-and-place run")
    args = parser.parse_args()
    parts = [p.strip() for p in args.only.split(",") if p.strip()]
    unknown = sorted(set(parts) - set(PARTS))
    if unknown:
        parser.error(f"--only: unknown part(s) {', '.join(unknown)} (parts: {', '.join(PARTS)})")
    args.out.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory() as scratch:
        drawers = {
            "variants": lambda: draw_variants(args.out),
            "arms": lambda: draw_arms(args.out, args.arms_dir or Path(scratch)),
            "grasps": lambda: draw_grasps(args.out),
            "pick_and_place": lambda: draw_pick_and_place(args.out, args.pick_and_place),
            "wireloop": lambda: draw_wireloop(args.out, Path(scratch)),
            "learning": lambda: draw_learning(args.out),
        }
        for part in parts:
            for path in drawers[part]():
                print(f"wrote {path}", flush=True)


if __name__ == "__main__":
    main()
