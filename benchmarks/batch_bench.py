"""World-steps per second of ``svhdesc.batch`` (MuJoCo Warp) against nworld, beside single-thread MuJoCo C.

    python benchmarks/batch_bench.py                         # CPU device, nworld 1..256
    python benchmarks/batch_bench.py --device cuda           # a GPU, nworld 1..4096
    python benchmarks/batch_bench.py --max-nworld 4096       # more worlds on the CPU too (slow)
    python benchmarks/batch_bench.py --device cuda --grasp --max-nworld 65536   # contact-rich, until it no longer fits

Every world starts at keyframe home and is driven towards its own random servo targets (fixed seed) for
--steps physics steps after a warm-up call (which compiles Warp's kernels, cached in .cache/warp, and on a
GPU captures the step graph). The reference, in the same run: one MuJoCo C MjData stepped on one thread with
the same scene and targets. Prints one row per nworld and the ratio to MuJoCo C, and writes them to
docs/results/batch.md (other variants, devices and --grasp: batch_<variant>_gpu_grasp.md and the like).
The goal for a GPU is 1,000,000 hand steps/s for svh_right on one H100. Not a test: machines are noisy.
"""

from __future__ import annotations

import argparse
import os
import re
import sys
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))
os.environ.setdefault("WARP_CACHE_PATH", str(REPO / ".cache" / "warp"))

import mujoco  # noqa: E402

import svhdesc  # noqa: E402
from svhdesc.batch.env import BatchOverflow  # noqa: E402

sys.path.insert(0, str(REPO / "benchmarks"))
from results import cpu_model, write  # noqa: E402

CPU_NOTE = [
    "On a CPU, Warp is meant for GPUs, not to beat one MuJoCo C thread (the ratio column; all figures move with the",
    "other jobs on a shared machine). A GPU's figures: `python benchmarks/batch_bench.py --device cuda` (nworld 1 to",
    "4096, the step replayed as a captured CUDA graph) writes `docs/results/batch_gpu_<model>.md`. The goal of",
    "1,000,000 hand steps/s on one H100 ([speed.md](/docs/speed.md)) is measured only there.",
]


def targets(model: mujoco.MjModel, nworld: int, grasp: bool) -> np.ndarray:
    if grasp:  # every world closes on its object: the power keyframe's servo targets
        return np.tile(model.key("power").ctrl, (nworld, 1))
    low, high = model.actuator_ctrlrange.T
    return np.random.default_rng(0).uniform(low, high, (nworld, model.nu))


def scene(variant: str, grasp: bool) -> mujoco.MjModel:
    """The variant's batch scene; with ``grasp``, the `power` grasp's object welded in the open hand (as the
    grasps check places it, config/svhdesc.yaml), so every world closes its fingers on it."""
    path = svhdesc.get(variant).batch_scene_path
    if not grasp:
        return mujoco.MjModel.from_xml_path(str(path))
    import yaml

    from svhdesc.validate import grasps
    from svhdesc.validate.handsim import find_hand

    config = yaml.safe_load((REPO / "config" / "svhdesc.yaml").read_text())["grasps"]["power"]
    model = mujoco.MjModel.from_xml_path(str(path))
    hand = find_hand(model, svhdesc.get(variant).hand)
    placement, _ = grasps._placement(model, hand, config)
    return grasps._scene(path, config, placement, f"{hand.prefix}_base_link").compile()


def start_key(grasp: bool) -> str:
    return "open" if grasp else "home"


def mujoco_c_rate(model: mujoco.MjModel, grasp: bool, steps: int) -> float:
    data = mujoco.MjData(model)
    mujoco.mj_resetDataKeyframe(model, data, model.key(start_key(grasp)).id)
    data.ctrl[:] = targets(model, 1, grasp)[0]
    start = time.perf_counter()
    for _ in range(steps):
        mujoco.mj_step(model, data)
    return steps / (time.perf_counter() - start)


def warp_rate(
    model: mujoco.MjModel, grasp: bool, nworld: int, device: str, steps: int, njmax: int | None = None
) -> float:
    from svhdesc.batch.env import BatchEnv  # after quiet_init: importing it would start Warp with its banner

    env = BatchEnv(model, nworld=nworld, device=device, njmax=njmax)
    env.reset(start_key(grasp))
    ctrl = targets(model, nworld, grasp)
    for _ in range(2):  # warm-up: kernels compiled (first call), on a GPU the step graph captured (second)
        env.step(ctrl, nstep=steps)
    env.reset(start_key(grasp))
    start = time.perf_counter()
    env.step(ctrl, nstep=steps)  # ends with the overflow check, which waits for the device
    return nworld * steps / (time.perf_counter() - start)


def quiet_init(device: str) -> str:
    """Start Warp quietly (svhdesc.batch.device); the device's name, or exit 2 where there is no such device."""
    import warp as wp

    from svhdesc.batch.device import warp_device
    from svhdesc.errors import SvhdescError

    try:
        found = warp_device(wp, device)
    except SvhdescError as exc:
        print(f"error: {exc}", file=sys.stderr)
        raise SystemExit(2) from None
    return found.name if device.startswith("cuda") else cpu_model()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--variant", default="svh_right")
    parser.add_argument("--device", default="cpu", help="cpu, cuda, cuda:N")
    parser.add_argument("--max-nworld", type=int, default=None, help="default 256 on cpu, 4096 on cuda")
    parser.add_argument(
        "--steps", type=int, default=None, help="physics steps timed per nworld (default 100 cpu, 1000 cuda)"
    )
    parser.add_argument(
        "--grasp", action="store_true", help="contact-rich: every world closes the power grasp on its object"
    )
    parser.add_argument(
        "--budget",
        type=float,
        default=None,
        help="seconds: start no row that would end past this (the page says where it stopped)",
    )
    parser.add_argument(
        "--njmax", type=int, default=None, help="constraint rows per world instead of the model's <size njmax>"
    )
    args = parser.parse_args()
    gpu = args.device.startswith("cuda")
    largest = args.max_nworld or (4096 if gpu else 256)
    steps = args.steps or (1000 if gpu else 100)
    name = quiet_init(args.device)
    model = scene(args.variant, args.grasp)
    reference = mujoco_c_rate(model, args.grasp, 2000)
    what = "closing the power grasp on its object" if args.grasp else "random servo targets"
    sizes = f"capacities nconmax={model.nconmax}, njmax={args.njmax or model.njmax}"
    if args.njmax is not None:
        sizes += f" (the model's {model.njmax}, set by --njmax)"
    lines = [
        f"{args.variant}, {what}, on {args.device} ({name}); {steps} steps timed per row; {sizes} per world",
        "",
        f"MuJoCo C, one thread, same scene: {reference:,.0f} steps/s",
        "",
        "| nworld | world-steps/s | x MuJoCo C |",
        "|---|---|---|",
    ]
    for line in lines:
        print(line)
    rate, nworld, began, next_row = 0.0, 1, time.perf_counter(), 0.0
    while nworld <= largest:
        if args.budget is not None and time.perf_counter() - began + next_row > args.budget:
            lines.append(f"| {nworld} | not run: the next row would pass the {args.budget:.0f} s budget | |")
            print(lines[-1])
            break
        try:
            rate = warp_rate(model, args.grasp, nworld, args.device, steps, args.njmax)
        except BatchOverflow as error:  # a world needed more than its capacities: no figure past this row
            lines.append(f"| {nworld} | overflow: {str(error).split('; capacities')[0]} | |")
            print(lines[-1])
            break
        except (RuntimeError, MemoryError) as error:  # Warp's allocation failure: the previous row was the largest
            lines.append(f"| {nworld} | does not fit: {(str(error) or type(error).__name__).splitlines()[0]} | |")
            print(lines[-1])
            break
        lines.append(f"| {nworld} | {rate:,.0f} | {rate / reference:.2f} |")
        print(lines[-1], flush=True)
        next_row = 3 * 4 * nworld * steps / rate  # a row steps three times (two warm-ups), the next 4x the worlds
        nworld *= 4
    if gpu:
        lines += ["", f"goal: 1,000,000 world-steps/s ({'met' if rate >= 1e6 else 'not met'} at the largest row)"]
        print(lines[-1])
    else:
        lines += ["", *CPU_NOTE]
    path = write(
        page_name(args.variant, name if gpu else None, args.grasp, args.njmax),
        f"Batch (MuJoCo Warp): {args.variant} on {args.device}",
        lines,
    )
    print(f"wrote {path.relative_to(REPO)}")


def page_name(variant: str, gpu: str | None, grasp: bool, njmax: int | None = None) -> str:
    """docs/results/batch.md for the default run (svh_right, CPU, random targets); the others beside it, a GPU's
    named by its model (``NVIDIA H100 80GB HBM3`` -> ``_gpu_h100``), so each card's rows keep their own page."""
    return (
        "batch"
        + ("" if variant == "svh_right" else f"_{variant}")
        + ("" if gpu is None else gpu_tag(gpu))
        + ("_grasp" if grasp else "")
        + ("" if njmax is None else f"_njmax{njmax}")
    )


def gpu_tag(name: str) -> str:
    model = re.search(r"\b[A-Z]+\d+\w*\b", name)
    return "_gpu" + (f"_{model.group(0).lower()}" if model else "")


if __name__ == "__main__":
    main()
