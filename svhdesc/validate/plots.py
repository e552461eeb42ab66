"""PNG time series of the contact experiment (joint positions, contact force), like thesis Figs. 5.17/5.18."""

from __future__ import annotations

from pathlib import Path
from typing import Protocol

import numpy as np


class ContactRun(Protocol):
    """What the plots read of a contact experiment (svhdesc.validate.contact_stability.Experiment); a protocol, so
    that the check imports the plots and not the other way round."""

    joints: list[str]
    time: np.ndarray
    qpos: np.ndarray
    force: np.ndarray
    touch: np.ndarray
    record_from: int


def plot_contact(run: ContactRun, name: str, directory: Path) -> list[Path]:
    import matplotlib

    matplotlib.use("Agg")  # headless: no display needed
    import matplotlib.pyplot as plt

    directory.mkdir(parents=True, exist_ok=True)
    start = run.time[run.record_from] if run.record_from < len(run.time) else run.time[-1]
    hand = [i for i, n in enumerate(run.joints) if "_hand_" in n]
    arm = [i for i in range(len(run.joints)) if i not in hand]
    groups = [(title, idx) for title, idx in (("arm joints", arm), ("hand joints", hand)) if idx]

    joints_png = directory / f"{name}_contact_joints.png"
    fig, axes = plt.subplots(len(groups), 1, figsize=(10, 4 * len(groups)), sharex=True, squeeze=False)
    for axis, (title, indices) in zip(axes[:, 0], groups, strict=True):
        for i in indices:
            axis.plot(
                run.time,
                run.qpos[:, i],
                linewidth=0.8,
                label=run.joints[i].removeprefix("right_hand_").removeprefix("left_hand_"),
            )
        axis.axvspan(start, run.time[-1], color="0.9", zorder=0)
        axis.set_ylabel("position [rad]")
        axis.set_title(f"{name}: {title} (recorded window shaded)")
        axis.legend(fontsize=6, ncol=4, loc="best")
        axis.grid(True, linewidth=0.3)
    axes[-1, 0].set_xlabel("time [s]")
    fig.tight_layout()
    fig.savefig(joints_png, dpi=110)
    plt.close(fig)

    force_png = directory / f"{name}_contact_force.png"
    fig, axis = plt.subplots(figsize=(10, 4))
    axis.plot(run.time, run.force, linewidth=0.8, label="normal force (mj_contactForce)")
    axis.plot(run.time, run.touch, linewidth=0.8, linestyle="--", label="touch sensor")
    axis.axvspan(start, run.time[-1], color="0.9", zorder=0)
    axis.set_xlabel("time [s]")
    axis.set_ylabel("force [N]")
    axis.set_title(f"{name}: fingertip contact force on the surface")
    axis.legend(fontsize=8)
    axis.grid(True, linewidth=0.3)
    fig.tight_layout()
    fig.savefig(force_png, dpi=110)
    plt.close(fig)
    return [joints_png, force_png]
