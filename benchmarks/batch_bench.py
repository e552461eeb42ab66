"""World-steps per second of ``svhdesc.batch`` (MuJoCo Warp) against nworld, beside single-thread MuJoCo C.

    python benchmarks/batch_bench.py                         # CPU device, nworld 1..256
    python benchmarks/batch_bench.py --device cuda           # a GPU, nworld 1..4096
    python benchmarks/batch_bench.py --max-nworld 4096       # more worlds on the CPU too (slow)

Every world starts at keyframe home and is driven towards its own random servo targets (fixed seed) for
--steps physics steps after a warm-up call (which compiles Warp's kernels, cached in .cache/warp, and on a
GPU captures the step graph). The reference, in the same run: one MuJoCo C MjData stepped on one thread with
the same scene and targets. Prints one row per nworld and the ratio to MuJoCo C.
The goal for a GPU is 1,000,000 hand steps/s for svh_right on one H100. Not a test: machines are noisy.
"""

from __future__ import annotations

import argparse
import os
import platform
import sys
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))
os.environ.setdefault("WARP_CACHE_PATH", str(REPO / ".cache" / "warp"))

import mujoco  # noqa: E402

import svhdesc  # noqa: E402
from svhdesc.batch import make  # noqa: E402


def targets(model: mujoco.MjModel, nworld: int) -> np.ndarray:
    low, high = model.actuator_ctrlrange.T
    return np.random.default_rng(0).uniform(low, high, (nworld, model.nu))


def mujoco_c_rate(variant: str, steps: int) -> float:
    model = mujoco.MjModel.from_xml_path(str(svhdesc.get(variant).batch_scene_path))
    data = mujoco.MjData(model)
    mujoco.mj_resetDataKeyframe(model, data, model.key("home").id)
    data.ctrl[:] = targets(model, 1)[0]
    start = time.perf_counter()
    for _ in range(steps):
        mujoco.mj_step(model, data)
    return steps / (time.perf_counter() - start)


def warp_rate(variant: str, nworld: int, device: str, steps: int) -> float:
    env = make(variant, nworld=nworld, device=device)
    env.reset("home")
    ctrl = targets(env.mjm, nworld)
    for _ in range(2):  # warm-up: kernels compiled (first call), on a GPU the step graph captured (second)
        env.step(ctrl, nstep=steps)
    env.reset("home")
    start = time.perf_counter()
    env.step(ctrl, nstep=steps)  # ends with the overflow check, which waits for the device
    return nworld * steps / (time.perf_counter() - start)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--variant", default="svh_right")
    parser.add_argument("--device", default="cpu", help="cpu, cuda, cuda:N")
    parser.add_argument("--max-nworld", type=int, default=None, help="default 256 on cpu, 4096 on cuda")
    parser.add_argument(
        "--steps", type=int, default=None, help="physics steps timed per nworld (default 100 cpu, 1000 cuda)"
    )
    args = parser.parse_args()
    gpu = args.device.startswith("cuda")
    largest = args.max_nworld or (4096 if gpu else 256)
    steps = args.steps or (1000 if gpu else 100)
    import warp as wp

    wp.config.quiet = True
    wp.init()
    name = wp.get_device(args.device).name if gpu else f"{platform.processor() or platform.machine()} CPU"
    reference = mujoco_c_rate(args.variant, 2000)
    print(f"{args.variant} on {args.device} ({name}), {os.cpu_count()} cores; {steps} steps timed per row")
    print(f"MuJoCo C, one thread, same scene: {reference:,.0f} steps/s")
    print(f"{'nworld':>7} {'world-steps/s':>14} {'x MuJoCo C':>11}")
    nworld = 1
    while nworld <= largest:
        rate = warp_rate(args.variant, nworld, args.device, steps)
        print(f"{nworld:>7} {rate:>14,.0f} {rate / reference:>11.2f}", flush=True)
        nworld *= 4
    if gpu:
        print(f"goal: 1,000,000 world-steps/s at 4096 worlds ({'met' if rate >= 1e6 else 'not met'})")


if __name__ == "__main__":
    main()
