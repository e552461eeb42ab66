"""PNG time series of the contact experiment (joint positions, contact force), like thesis Figs. 5.17/5.18."""

from __future__ import annotations

from pathlib import Path
from typing import Protocol

import numpy as np

from svhdesc.compare.figures import Traces, plot_joints
from svhdesc.model import HandId


class ContactRun(Traces, Protocol):
    """What the plots read of a contact experiment (svhdesc.validate.contact_stability.Experiment); a protocol, so
    that the check imports the plots and not the other way round."""

    joints: list[str]
    time: np.ndarray
    qpos: np.ndarray
    force: np.ndarray
    touch: np.ndarray
    record_from: int


def plot_contact(run: ContactRun, name: str, hand: HandId | None, directory: Path) -> list[Path]:
    """The joints (``hand``: the built model's, whose joints form the hand panel) and the contact force."""
    import matplotlib

    matplotlib.use("Agg")  # headless: no display needed
    import matplotlib.pyplot as plt

    directory.mkdir(parents=True, exist_ok=True)
    start = run.time[min(run.record_from, len(run.time) - 1)]
    joints_png = plot_joints(run, hand, directory / f"{name}_contact_joints.png", name)

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
