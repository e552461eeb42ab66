"""Figures like the paper's: covered distance per training cycle (Fig. 6) and the loop's path (Figs. 7-8)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from svhdesc.wireloop.env import Environment, limit_offsets

PNG_METADATA = {"Software": None}  # no version string: the same run gives the same bytes


def _pyplot() -> Any:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def plot_distances(distances: list[int], total: int, out: Path, title: str) -> None:
    plt = _pyplot()
    fig, ax = plt.subplots(figsize=(6, 3.6), dpi=100)
    cycles = list(range(1, len(distances) + 1))
    ax.plot(cycles, distances, marker="o", markersize=3)
    ax.axhline(total, color="grey", linestyle="--", linewidth=1, label="end of the wire")
    ax.set_xlabel("training cycle")
    ax.set_ylabel("covered distance (pixels along the wire)")
    ax.set_title(title)
    ax.legend(loc="lower right")
    ax.grid(True, alpha=0.3)
    fig.tight_layout()
    fig.savefig(out, metadata=PNG_METADATA)
    plt.close(fig)


def plot_run(env: Environment, codes: list[int], out: Path, title: str, every: int = 1) -> None:
    """The wire (black), the loop's middle point (blue) and the loop itself (red) at each step of a run."""
    plt = _pyplot()
    wire_map = env.map
    fig, ax = plt.subplots(figsize=(wire_map.cols / 5 + 1, wire_map.rows / 5 + 1), dpi=100)
    rows = [r for r, _ in wire_map.path]
    cols = [c for _, c in wire_map.path]
    ax.plot(cols, rows, color="black", linewidth=2.5, label="wire")
    ax.plot(cols[0], rows[0], "gs", label="start")
    ax.plot(cols[-1], rows[-1], "ks", label="end")
    points = [env.row_col(code >> 2) + (code & 3,) for code in codes if code >= 0]
    if points:
        ax.plot([p[1] for p in points], [p[0] for p in points], color="tab:blue", linewidth=1, label="loop middle")
        for i, (r, c, rotation) in enumerate(points):
            if i % every:
                continue
            dr, dc = limit_offsets(env.config.loop_radius, 45.0 * rotation)
            ax.plot([c - dc, c + dc], [r - dr, r + dr], color="tab:red", linewidth=0.8, alpha=0.6)
    ax.set_xlim(-0.5, wire_map.cols - 0.5)
    ax.set_ylim(wire_map.rows - 0.5, -0.5)
    ax.set_aspect("equal")
    ax.set_title(title)
    ax.legend(loc="upper right", fontsize=7)
    fig.tight_layout()
    fig.savefig(out, metadata=PNG_METADATA)
    plt.close(fig)
