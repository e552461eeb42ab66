"""mjlab's training beside ``svhdesc train`` on the same task, worlds and device: env-steps/s of each PPO iteration
(the rollout's env-steps over the iteration's wall time, collection and update), writing docs/results/mjlab.md
(``_gpu_<model>`` for a GPU).

    python benchmarks/mjlab_bench.py [--envs 32] [--iterations 4] [--device cpu|cuda]

Each framework runs in its own environment and process, as a user runs it: ``svhdesc train TASK`` in this one
(MuJoCo Warp 4.0, the batch model, rsl-rl 5.5), mjlab's own ``train`` (``mjlab.scripts.train``) on the matching
task in .venv-mjlab (MuJoCo Warp 3.11, the same batch model through svhdesc.mjlab's entity, rsl-rl 5.4). Both PPO
configurations are svhdesc.learn's (24 steps per world and iteration). The first iteration is left out of the
median: it loads (or compiles) Warp's kernels.
"""

from __future__ import annotations

import argparse
import re
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from results import REPO, cpu_model, write  # noqa: E402

PAIRS = (("svh_rotate", "Svh-Rotate"), ("ur5_lift", "Ur5-Svh-Lift"))
STEPS_PER_ENV = 24  # both tasks', both frameworks'
MJLAB_PYTHON = REPO / ".venv-mjlab" / "bin" / "python"
TIMEOUT = 1800  # s a run may take


def svhdesc_rates(task: str, envs: int, iterations: int, device: str, out: Path) -> list[float]:
    """env-steps/s of each iteration, as svhdesc train's progress lines print them."""
    command = [sys.executable, "-m", "svhdesc.cli", "train", task, "--device", device, "--envs", str(envs)]
    command += ["--iterations", str(iterations), "--out", str(out)]
    text = _run(command)
    return [float(m.replace(",", "")) for m in re.findall(r"([\d,]+) env-steps/s", text)]


def mjlab_rates(task: str, envs: int, iterations: int, device: str, out: Path) -> tuple[list[float], float]:
    """env-steps/s of each iteration of mjlab's train (the rollout over rsl-rl's collection plus learning time), and
    the share of the iterations after the first that collection took."""
    gpus = "None" if device == "cpu" else "[0]"
    command = [str(MJLAB_PYTHON), "-m", "mjlab.scripts.train", task, "--env.scene.num-envs", str(envs)]
    command += ["--agent.max-iterations", str(iterations), "--gpu-ids", gpus, "--log-root", str(out)]
    text = _run(command, {"MJLAB_WARP_QUIET": "1"})
    collect = [float(t) for t in re.findall(r"Collection time:\s*([\d.]+)s", text)]
    learn = [float(t) for t in re.findall(r"Learning time:\s*([\d.]+)s", text)]
    rates = [envs * STEPS_PER_ENV / (c + u) for c, u in zip(collect, learn, strict=True)]
    later = slice(1, None) if len(collect) > 1 else slice(None)
    share = sum(collect[later]) / max(sum(collect[later]) + sum(learn[later]), 1e-9)
    return rates, share


FAILURES: list[str] = []  # runs that ended before their last iteration: the page says why


def _run(command: list[str], env: dict[str, str] | None = None) -> str:
    import os

    print("+", " ".join(command), flush=True)
    done = subprocess.run(
        command, capture_output=True, text=True, cwd=REPO, env={**os.environ, **(env or {})}, timeout=TIMEOUT
    )
    if done.returncode != 0:
        last = (done.stderr.strip().splitlines() or ["(no output)"])[-1]
        FAILURES.append(
            f"`{' '.join(Path(c).name if '/' in c else c for c in command[:5])}` exited {done.returncode}: {last}"
        )
    return done.stdout + done.stderr


def row(name: str, rates: list[float], collecting: float | None = None) -> str:
    share = f"{100 * collecting:.0f} %" if collecting is not None and rates else "-"
    if not rates:
        return f"| {name} | 0 | - | - | - |"
    steady = rates[1:] or rates
    return f"| {name} | {len(rates)} | {rates[0]:,.0f} | {statistics.median(steady):,.0f} | {share} |"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--envs", type=int, default=32)
    parser.add_argument("--iterations", type=int, default=4)
    parser.add_argument("--device", choices=("cpu", "cuda"), default="cpu")
    args = parser.parse_args(argv)
    lines = [
        f"{args.envs} worlds, {args.iterations} PPO iterations of {STEPS_PER_ENV} steps a world, on {args.device} "
        f"({cpu_model() if args.device == 'cpu' else 'GPU 0'}); env-steps/s = a rollout's env-steps over the "
        "iteration's wall time (collection and update); the first iteration loads Warp's kernels; collecting: the "
        "share of mjlab's iterations after the first that its rollout took (rsl-rl's collection time; svhdesc train "
        "prints no split)",
        "",
        "| task | iterations | first iteration, env-steps/s | median of the others, env-steps/s | collecting |",
        "|---|---|---|---|---|",
    ]
    with tempfile.TemporaryDirectory() as folder:
        for ours, theirs in PAIRS:
            mine = svhdesc_rates(ours, args.envs, args.iterations, args.device, Path(folder) / ours)
            lines.append(row(f"`svhdesc train {ours}`", mine))
            print(lines[-1], flush=True)
            other, collecting = mjlab_rates(theirs, args.envs, args.iterations, args.device, Path(folder) / "mjlab")
            lines.append(row(f"mjlab `train {theirs}`", other, collecting))
            print(lines[-1], flush=True)
    if FAILURES:
        lines += [
            "",
            "Runs that ended before their last iteration (their rows count the iterations they finished):",
            "",
        ]
        lines += [f"- {failure}" for failure in FAILURES]
    lines += ["", *NOTES]
    name = "mjlab" if args.device == "cpu" else "mjlab_gpu"
    print(write(name, f"mjlab beside svhdesc train: {args.device}", lines))
    return 0


NOTES = [
    "Both run the same batch model (svhdesc.mjlab's entity reads it), the same physics step and control rate, the "
    "same network and PPO settings (svhdesc.learn's), each with its own managers: svhdesc.learn's terms and resets, "
    "or mjlab's observation, reward, termination, event and command managers (docs/learning.md, In mjlab). On a "
    "shared 2-core machine the absolute figures move with the other jobs; the two rows of a task ran one after the "
    "other.",
    "",
    "On a GPU (unmeasured here: no GPU in the session that wrote this page), the same script with `--device cuda` "
    "writes `mjlab_gpu.md`: `python benchmarks/mjlab_bench.py --device cuda --envs 4096 --iterations 10`, which "
    "runs `svhdesc train TASK --device cuda --envs 4096 --iterations 10` and mjlab's "
    "`train TASK --env.scene.num-envs 4096 --agent.max-iterations 10 --gpu-ids [0]`.",
]


if __name__ == "__main__":
    raise SystemExit(main())
