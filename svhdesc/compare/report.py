"""The comparison as Markdown (shaped like thesis Tables 5.1/5.2), JSON, CSV and plots (Figs. 5.16-5.18)."""

from __future__ import annotations

import csv
import json
import math
from pathlib import Path
from typing import Any

from svhdesc.compare.experiment import Conditions, Setup, moving_mean, window_span
from svhdesc.compare.figures import plot_joints
from svhdesc.compare.runner import FORCE_WINDOW, STATUS_MISSING, STATUS_OK, TIP_TOLERANCE, Result
from svhdesc.model import HandId, get


def _sci(value: float | None) -> str:
    if value is None or not math.isfinite(value):
        return "-"
    return "0" if value == 0 else f"{value:.2e}"


def _column(result: Result) -> str:
    return f"{result.engine} {result.label}"


def heading(conditions: Conditions) -> str:
    """What the figures were computed with: the window, the sampling, the force, the setup."""
    before, after = window_span(10, conditions.window)
    setup = "thesis setup (--thesis-setup)" if conditions.thesis else "this project's setup"
    return (
        f"eq. 5.1, window 10 {conditions.window} ({before} before, {after} after), "
        f"{1 / conditions.sample_dt:g} Hz, {conditions.force} force, {setup}"
    )


def markdown(setup: Setup, results: list[Result], variant: str, conditions: Conditions | None = None) -> str:
    """Rows: the actuated joints (as Tables 5.1/5.2 list them), their average, then force, coupling,
    pose, speed and status; one column per engine x inertia."""
    conditions = conditions or Conditions()
    lines = [f"### {variant}: MAD of joint positions [rad] ({heading(conditions)}), fingertip on the surface", ""]
    header = ["joint", *(_column(r) for r in results)]
    lines.append("| " + " | ".join(header) + " |")
    lines.append("|" + "---|" * len(header))

    def row(name: str, cells: list[str]) -> None:
        lines.append("| " + " | ".join([name, *cells]) + " |")

    hand = get(variant).hand or HandId(None, None)
    for joint in setup.actuated:
        row(hand.short(joint), [_sci(r.mad.get(joint)) if r.status == STATUS_OK else "-" for r in results])
    row("**Average**", [f"**{_sci(r.mad_average)}**" if r.status == STATUS_OK else "-" for r in results])
    coupled = [c.joint for c in setup.couplings]
    row(
        "max MAD, coupled joints",
        [_sci(max((r.mad[j] for j in coupled if j in r.mad), default=None)) for r in results],
    )
    row("force mean [N]", [_fixed(r.force_mean, 3) for r in results])
    row("force std [N]", [_sci(r.force_std) for r in results])
    row("samples in contact", [_percent(r.contact_share) for r in results])
    row("worst coupling residual, approach [rad]", [_sci(r.coupling_residual_free) for r in results])
    row("worst coupling residual, whole run [rad]", [_sci(r.coupling_residual) for r in results])
    row(
        f"fingertip error [mm] (reached <= {TIP_TOLERANCE * 1e3:g})",
        [
            "-" if not math.isfinite(r.tip_error) else f"{r.tip_error * 1e3:.2f} {'yes' if r.reached else 'NO'}"
            for r in results
        ],
    )
    row("real-time factor", [_fixed(r.realtime_factor, 2) for r in results])
    row("status", [_status(r) for r in results])
    lines.append("")
    lines.append("Deviations from the thesis:")
    for item in conditions.describe()["deviations"]:
        lines.append(f"- **{item['what']}**: thesis {item['thesis']}; here {item['here']} ({item['why']})")
    lines.append("")
    lines.append("Solver settings:")
    seen: set[str] = set()
    for result in results:
        if result.engine in seen or not result.settings:
            continue
        seen.add(result.engine)
        lines.append(f"- **{result.engine}**: " + ", ".join(f"{k} {v}" for k, v in result.settings.items()))
    return "\n".join(lines)


# Thesis Tables 5.1 (Gazebo) and 5.2 (MuJoCo, on its 0.09 kg model): average MAD over the 15 joints [rad].
THESIS = {"Gazebo (thesis Table 5.1)": {"0.001": 5.1799e-05, "0.01": 5.8178e-06, "0.1": 5.7914e-06}}
THESIS_MUJOCO = {"MuJoCo (thesis Table 5.2, 0.09 kg robot)": {"0.1": 4.3664e-17}}


def summary(results: list[Result], conditions: Conditions | None = None) -> str:
    """Compact tables for the README: average MAD per engine x inertia beside the thesis' averages, then
    force, coupling, pose and speed per run."""
    conditions = conditions or Conditions()
    labels = list(dict.fromkeys(r.label for r in results))
    engines = list(dict.fromkeys(r.engine for r in results))
    by_key = {(r.engine, r.label): r for r in results}
    lines = [f"({heading(conditions)})", ""]
    lines.append("| average MAD [rad] | " + " | ".join(f"inertia {label}" for label in labels) + " |")
    lines.append("|" + "---|" * (len(labels) + 1))
    for name, row in {**THESIS, **THESIS_MUJOCO}.items():
        lines.append(f"| {name} | " + " | ".join(_sci(row.get(label)) for label in labels) + " |")
    for engine in engines:
        cells = []
        for label in labels:
            run = by_key.get((engine, label))
            if run is None:
                cells.append("")
            elif run.status == STATUS_OK:
                cells.append(_sci(run.mad_average))
            else:
                cells.append(run.status + (f" at {run.failed_at:.2f} s" if run.failed_at is not None else ""))
        lines.append(f"| {engine} | " + " | ".join(cells) + " |")
    lines += [
        "",
        "| engine | inertia | force mean +- std [N] | in contact | coupling residual approach / run [rad] "
        "| fingertip error [mm] | real-time factor |",
        "|---|---|---|---|---|---|---|",
    ]
    for run in results:
        if run.status != STATUS_OK:
            lines.append(f"| {run.engine} | {run.label} | {_status(run)} | | | | |")
            continue
        lines.append(
            f"| {run.engine} | {run.label} | {run.force_mean:.3g} +- {run.force_std:.2g} | "
            f"{_percent(run.contact_share)} | {_sci(run.coupling_residual_free)} / {_sci(run.coupling_residual)} | "
            f"{run.tip_error * 1e3:.1f} | {_fixed(run.realtime_factor, 2)} |"
        )
    return "\n".join(lines)


def _status(run: Result) -> str:
    if run.status == STATUS_MISSING:
        return run.note  # already "not installed (pip install ...)"
    return run.status + (f": {run.note}" if run.note else "")


def _fixed(value: float, digits: int) -> str:
    return "-" if not math.isfinite(value) else f"{value:.{digits}g}"


def _percent(value: float) -> str:
    return "-" if not math.isfinite(value) else f"{value:.0%}"


def write_json(
    path: Path,
    variant: str,
    setup: Setup,
    results: list[Result],
    duration: float | None,
    conditions: Conditions | None = None,
) -> None:
    conditions = conditions or Conditions()
    experiment = setup.description(results[0].settings.get("timestep", 0.001) if results else 0.001)
    document: dict[str, Any] = {
        "variant": variant,
        "duration_s": duration,
        "experiment": {**experiment, **conditions.describe()},
        "friction": setup.friction,
        "results": [r.summary() for r in results],
    }
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(document, indent=2, sort_keys=True) + "\n")


CSV_FIELDS = [
    "engine",
    "inertia",
    "status",
    "joint",
    "mad_rad",
    "mad_window",
    "force",
    "mad_average_rad",
    "force_mean_n",
    "force_std_n",
    "contact_share",
    "coupling_residual_before_contact_rad",
    "coupling_residual_rad",
    "tip_error_m",
    "test_pose_reached",
    "realtime_factor",
    "failed_at_s",
    "note",
]


def write_csv(path: Path, results: list[Result]) -> None:
    """Long format: one row per engine x inertia x joint, the run's figures repeated on each."""
    path.parent.mkdir(parents=True, exist_ok=True)
    with path.open("w", newline="") as handle:
        writer = csv.DictWriter(handle, CSV_FIELDS, lineterminator="\n")
        writer.writeheader()
        for result in results:
            summary = result.summary()
            common = {k: summary[k] for k in CSV_FIELDS if k in summary}
            common["inertia"] = result.label
            for joint in result.joints if result.mad else [""]:
                writer.writerow({**common, "joint": joint, "mad_rad": result.mad.get(joint, "")})


def plot(results: list[Result], directory: Path, variant: str) -> list[Path]:
    """Per engine x inertia: joint traces (Figs. 5.1-5.15, 5.18) and the force with its moving mean (5.16/5.17)."""
    import matplotlib

    matplotlib.use("Agg")  # headless: no display needed
    import matplotlib.pyplot as plt

    directory.mkdir(parents=True, exist_ok=True)
    hand = get(variant).hand
    written = []
    for result in results:
        if not len(result.time):
            continue
        stem = f"{variant}_{result.engine}_{result.label}"
        start = result.time[min(result.record_from, len(result.time) - 1)]
        heading = f"{result.engine}, finger inertia {result.label}"
        path = directory / f"{stem}_joints.png"
        written.append(plot_joints(result, hand, path, heading, "hand channels", result.actuated, (3.5, 100)))

        fig, axis = plt.subplots(figsize=(10, 3.5))
        axis.plot(result.time, result.force, color="black", linewidth=0.7, label="normal force")
        axis.plot(
            result.time,
            moving_mean(result.force, FORCE_WINDOW),
            color="red",
            linewidth=1.0,
            label=f"moving mean ({FORCE_WINDOW} samples)",
        )
        axis.axvspan(start, result.time[-1], color="0.9", zorder=0)
        _clip_impact(axis, result)
        axis.set_xlabel("time [s]")
        axis.set_ylabel("force [N]")
        axis.set_title(f"{result.engine}, finger inertia {result.label}: fingertip contact force")
        axis.legend(fontsize=8)
        axis.grid(True, linewidth=0.3)
        fig.tight_layout()
        path = directory / f"{stem}_force.png"
        fig.savefig(path, dpi=100)
        plt.close(fig)
        written.append(path)
    return written


def _clip_impact(axis: Any, run: Result) -> None:
    """Scale the force axis to the recorded window: the impact peak at first touch would flatten it."""
    recorded = run.force[run.record_from :]
    if not len(recorded):
        return
    top = max(1.5 * float(recorded.max()), 1.0)
    peak = float(run.force.max())
    axis.set_ylim(min(0.0, float(recorded.min())), top)
    if peak > top:
        axis.text(0.01, 0.95, f"impact peak {peak:.0f} N (clipped)", transform=axis.transAxes, fontsize=6, va="top")


def plot_overview(results: list[Result], path: Path) -> Path | None:
    """One figure like thesis Fig. 5.16: fingertip force and its moving mean, engines x inertia settings."""
    runs = [r for r in results if len(r.time)]
    if not runs:
        return None
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    engines = list(dict.fromkeys(r.engine for r in runs))
    labels = list(dict.fromkeys(r.label for r in runs))
    fig, axes = plt.subplots(
        len(engines), len(labels), figsize=(max(3.2 * len(labels), 6.0), 2.2 * len(engines)), sharex=True, squeeze=False
    )
    for axis in axes.flat:
        axis.set_visible(False)
    for run in runs:
        axis = axes[engines.index(run.engine), labels.index(run.label)]
        axis.set_visible(True)
        axis.plot(run.time, run.force, color="black", linewidth=0.5)
        axis.plot(run.time, moving_mean(run.force, FORCE_WINDOW), color="red", linewidth=0.9)
        _clip_impact(axis, run)
        axis.set_title(f"{run.engine}, inertia {run.label}", fontsize=8)
        axis.tick_params(labelsize=7)
        axis.grid(True, linewidth=0.3)
        if run.failed_at is not None:
            axis.axvline(run.failed_at, color="orange", linewidth=1.0)
    for axis in axes[-1, :]:
        axis.set_xlabel("time [s]", fontsize=8)
    for axis in axes[:, 0]:
        axis.set_ylabel("force [N]", fontsize=8)
    fig.suptitle("Index fingertip normal force (black) and its moving mean (red)", fontsize=9)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=90)
    plt.close(fig)
    return path
