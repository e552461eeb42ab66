"""The full chapter-5 comparison: every engine x finger-inertia setting, full-length runs (5 s each).

    python benchmarks/compare_bench.py [--duration S] [--out DIR] [--window centred|trailing] [--thesis-setup]

Prints the Markdown table (README, section "Engine comparison") and writes compare.json, compare.csv,
per-run plots and the overview figure compare_force.png under --out (default /tmp/svhdesc-compare).
CPU-heavy (DART and Drake run slower than real time on meshes): run it once, not in CI.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

from svhdesc.compare.experiment import Conditions
from svhdesc.compare.report import markdown, plot, plot_overview, summary, write_csv, write_json
from svhdesc.compare.runner import run_grid

ENGINES = ["mujoco", "dart", "bullet", "drake", "ode"]
INERTIAS: list[float | None] = [None, 0.001, 0.01, 0.1]


def window_table(results) -> str:  # noqa: ANN001 - runner.Result
    """Average MAD of the same recorded traces with the centred and the trailing window (eq. 5.1's two readings)."""
    import numpy as np

    from svhdesc.compare.experiment import mad

    lines = [
        "| engine | inertia | average MAD, centred [rad] | trailing [rad] | trailing / centred |",
        "|---|---|---|---|---|",
    ]
    for run in results:
        if run.status != "ok":
            continue
        recorded = run.qpos[run.record_from :]
        actuated = [run.joints.index(name) for name in run.actuated]
        centred = float(np.mean(mad(recorded[:, actuated], placement="centred")))
        trailing = float(np.mean(mad(recorded[:, actuated], placement="trailing")))
        ratio = f"{trailing / centred:.1f}" if centred > 0 else "-"
        lines.append(f"| {run.engine} | {run.label} | {centred:.2e} | {trailing:.2e} | {ratio} |")
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--variant", default="ur5_svh_right")
    parser.add_argument("--duration", type=float, default=None, help="seconds per run (default 5)")
    parser.add_argument("--out", type=Path, default=Path("/tmp/svhdesc-compare"))
    parser.add_argument("--window", choices=["centred", "trailing"], default="centred")
    parser.add_argument("--thesis-setup", action="store_true")
    parser.add_argument("--engines", default=",".join(ENGINES))
    args = parser.parse_args()
    conditions = Conditions(thesis=args.thesis_setup, window=args.window)
    started = time.perf_counter()

    def progress(result) -> None:  # noqa: ANN001 - runner.Result
        print(f"  {result.engine:>6} {result.label:>8}: {result.status} {result.note}", flush=True)

    engines = args.engines.split(",")
    setup, results = run_grid(args.variant, engines, INERTIAS, args.duration, progress, conditions)
    print(markdown(setup, results, args.variant, conditions))
    print()
    print(summary(results, conditions))
    print()
    print(window_table(results))
    write_json(args.out / "compare.json", args.variant, setup, results, args.duration, conditions)
    write_csv(args.out / "compare.csv", results)
    plot(results, args.out / "plots", args.variant)
    overview = plot_overview(results, args.out / "compare_force.png")
    print(f"\nwrote {args.out} (overview {overview}); {time.perf_counter() - started:.0f} s in all")


if __name__ == "__main__":
    main()
