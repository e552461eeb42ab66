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

from svhdesc.compare.engine import RunConfig
from svhdesc.compare.experiment import Conditions
from svhdesc.compare.ode_engine import OdeEngine
from svhdesc.compare.report import markdown, plot, plot_overview, summary, write_csv, write_json
from svhdesc.compare.runner import run_grid

ENGINES = ["mujoco", "dart", "bullet", "drake", "ode"]
INERTIAS: list[float | None] = [None, 0.001, 0.01, 0.1]


# Thesis Table 5.1 as printed, 1e-4 rad (the 0.001 column is printed in 1e-3 rad).
TABLE_5_1 = {
    "Finger_Spread": (0.240, 0.01541, 0.00111),
    "Index_Finger_Distal": (0.097, 0.00091, 0.00141),
    "Index_Finger_Proximal": (0.204, 0.00151, 0.00161),
    "Middle_Finger_Distal": (0.072, 0.00171, 0.01111),
    "Middle_Finger_Proximal": (0.196, 0.03041, 0.03261),
    "Pinky": (0.222, 0.02871, 0.03111),
    "Ring_Finger": (0.221, 0.03011, 0.03121),
    "Thumb_Flexion": (0.471, 0.01221, 0.00331),
    "Thumb_Opposition": (4.379, 0.05771, 0.00531),
    "shoulder_lift_joint": (0.151, 0.10011, 0.12251),
    "shoulder_pan_joint": (0.149, 0.02301, 0.01531),
    "elbow_joint": (0.173, 0.15331, 0.17551),
    "wrist_1_joint": (0.474, 0.34761, 0.38181),
    "wrist_2_joint": (0.603, 0.00921, 0.01131),
    "wrist_3_joint": (0.118, 0.06101, 0.04361),
}


def table_5_1() -> str:
    """What Table 5.1 itself says about the trend with inertia, joint by joint."""
    rising = [name for name, (_, mid, high) in TABLE_5_1.items() if high > mid]
    averages = [sum(column) / len(TABLE_5_1) * 1e-4 for column in zip(*TABLE_5_1.values(), strict=True)]
    return (
        f"thesis Table 5.1: averages {averages[0]:.4e} / {averages[1]:.4e} / {averages[2]:.4e} rad at 0.001 / 0.01 / "
        f"0.1 kg m^2; from 0.01 to 0.1, {len(rising)} of {len(TABLE_5_1)} joints rise ({', '.join(rising)})"
    )


class OdeWithoutDamping(OdeEngine):
    """ODE as Gazebo runs it, without the URDF's joint damping (for ``damping_probe``)."""

    name = "ode-undamped"

    def load(self, config: RunConfig) -> None:
        super().load(config)
        for joint in self.joint_info.values():
            joint.damping = 0.0


def damping_probe(variant: str, conditions: Conditions) -> str:
    """ODE at the physical inertials with and without the URDF's joint damping (applied explicitly, as Gazebo)."""
    from svhdesc.compare import runner

    runner.ENGINES.setdefault("ode-undamped", f"{__name__}:OdeWithoutDamping")
    _, results = run_grid(variant, ["ode", "ode-undamped"], [None], 1.0, None, conditions)
    return "; ".join(f"{r.engine} physical, 1 s: {r.status} {r.note}".strip() for r in results)


def ode_servos(variant: str, conditions: Conditions) -> str:
    """ODE with gazebo_ros_control's POSITION_PID (the comparison's kp/kv), without and with a gravity feedforward."""
    from svhdesc.compare import runner

    runner.ENGINES.setdefault("ode-pid", "svhdesc.compare.ode_engine:OdePid")
    runner.ENGINES.setdefault("ode-feedforward", "svhdesc.compare.ode_engine:OdeWithFeedforward")
    engines = ["ode-pid", "ode-feedforward"]
    _, results = run_grid(variant, engines, [0.001, 0.01, 0.1], None, None, conditions)
    lines = [
        "| ODE servo | inertia | average MAD [rad] | force mean +- std [N] | in contact | fingertip error [mm] |",
        "|---|---|---|---|---|---|",
    ]
    for run in results:
        if run.status != "ok":
            lines.append(f"| {run.engine} | {run.label} | {run.status} {run.note} | | | |")
            continue
        lines.append(
            f"| {run.engine} | {run.label} | {run.mad_average:.2e} | {run.force_mean:.3g} +- {run.force_std:.2g} | "
            f"{run.contact_share:.0%} | {run.tip_error * 1e3:.1f} |"
        )
    return "\n".join(lines)


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
    print()
    print(table_5_1())
    print()
    print(ode_servos(args.variant, conditions))
    print()
    print(damping_probe(args.variant, conditions))
    write_json(args.out / "compare.json", args.variant, setup, results, args.duration, conditions)
    write_csv(args.out / "compare.csv", results)
    plot(results, args.out / "plots", args.variant)
    overview = plot_overview(results, args.out / "compare_force.png")
    print(f"\nwrote {args.out} (overview {overview}); {time.perf_counter() - started:.0f} s in all")


if __name__ == "__main__":
    main()
