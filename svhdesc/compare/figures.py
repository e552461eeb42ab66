"""The joint-trace figure that the comparison (``svhdesc compare --plots``) and validate's contact check share: the
arm's joints and the hand's in two panels, the recorded window shaded, hand joints labelled without the built
model's prefix (``svhdesc.model.HandId``)."""

from __future__ import annotations

from collections.abc import Collection
from pathlib import Path
from typing import Protocol

import numpy as np

from svhdesc.model import HandId


class Traces(Protocol):
    """What the figure reads of a run (a compare ``Result``, validate's contact ``Experiment``)."""

    joints: list[str]
    time: np.ndarray
    qpos: np.ndarray
    record_from: int


def plot_joints(
    run: Traces,
    hand: HandId | None,
    path: Path,
    heading: str,
    hand_title: str = "hand joints",
    only: Collection[str] | None = None,
    size: tuple[float, int] = (4.0, 110),
) -> Path:
    """``run``'s joint positions to the PNG ``path``; ``only``: the hand joints to draw (default: all of them);
    ``size``: the height of a panel (inches) and the resolution (dpi)."""
    import matplotlib

    matplotlib.use("Agg")  # headless: no display needed
    import matplotlib.pyplot as plt

    owned = [hand is not None and hand.owns(name) for name in run.joints]
    hands = [i for i, name in enumerate(run.joints) if owned[i] and (only is None or name in only)]
    arm = [i for i in range(len(run.joints)) if not owned[i]]
    groups = [(title, idx) for title, idx in (("arm joints", arm), (hand_title, hands)) if idx]
    start = run.time[min(run.record_from, len(run.time) - 1)]
    height, dpi = size
    fig, axes = plt.subplots(len(groups), 1, figsize=(10, height * len(groups)), sharex=True, squeeze=False)
    for axis, (title, indices) in zip(axes[:, 0], groups, strict=True):
        for i in indices:
            label = hand.short(run.joints[i]) if hand is not None else run.joints[i]
            axis.plot(run.time, run.qpos[:, i], linewidth=0.8, label=label)
        axis.axvspan(start, run.time[-1], color="0.9", zorder=0)
        axis.set_ylabel("position [rad]")
        axis.set_title(f"{heading}: {title} (recorded window shaded)")
        axis.legend(fontsize=6, ncol=4, loc="best")
        axis.grid(True, linewidth=0.3)
    axes[-1, 0].set_xlabel("time [s]")
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=dpi)
    plt.close(fig)
    return path
