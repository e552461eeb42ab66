"""The solid described by the measured vendor slices (tools/vendor_slices.json), which authored parts are clipped to.

Per slab (x0 .. x0 + slab) the levels split into runs at gaps (a fork's slot has none); each run, mirrored in z,
is a polygon in the y-z plane whose sides join (yhi, z) and (ylo, z) level to level, extruded over the slab. A
level joins its neighbours linearly, which contains the part: each level's y-extent holds over its whole band,
and the bands of two neighbouring levels overlap between them. The polygon is built directly from the numbers
(plain arithmetic, no trigonometry or triangulator): the same bits on any CPU.

To keep the triangle count down, neighbouring slabs whose levels agree within MERGE become one (their wider
extent), and a level that its neighbours' line contains within SIMPLIFY is dropped: both only widen the solid.
"""

from __future__ import annotations

import json
from collections.abc import Sequence
from functools import cache
from pathlib import Path

import numpy as np
import trimesh

Level = tuple[float, float, float]  # (z, ylo, yhi), mm
DATA = Path(__file__).with_name("vendor_slices.json")
MERGE = 0.2  # mm
SIMPLIFY = 0.2  # mm
MIN_WIDTH = 0.2  # mm, narrowest y-extent of a level (a band that only grazes the surface)
LEVEL_STEP = 0.5  # mm between measured levels
WIDEN = 0.02  # mm
# Every face of the solid PAD further out: on the 0.1 mm grid of the numbers, its faces lay in the planes of the
# authored primitives' faces (x = 20, y = -6, ...), and the clipped part came out touching itself along an edge.
PAD = 0.013  # mm


def runs(levels: Sequence[Level]) -> list[list[Level]]:
    """Levels split at gaps (a missing level), each run mirrored in z; a run that starts at z = 0 spans both sides."""
    groups: list[list[Level]] = []
    for z, lo, hi in levels:
        level = (z, lo, max(hi, lo + MIN_WIDTH))
        if groups and z - groups[-1][-1][0] <= LEVEL_STEP + 1e-9:
            groups[-1].append(level)
        else:
            groups.append([level])
    out = []
    for group in groups:
        if len(group) == 1:  # a band that touches the surface only around one level
            z, lo, hi = group[0]
            group = [(max(z - LEVEL_STEP / 2, 0.0), lo, hi), (z + LEVEL_STEP / 2, lo, hi)]
        mirror = [(-z, lo, hi) for z, lo, hi in reversed(group)]
        if group[0][0] == 0.0:
            out.append(mirror[:-1] + group)
        else:
            out.extend([mirror, group])
    return out


def merged(slabs: Sequence[tuple[float, Sequence[Level]]]) -> list[tuple[float, float, list[Level]]]:
    """[(x_lo, x_hi, levels)]: neighbouring slabs with the same levels and y within MERGE joined."""
    out: list[tuple[float, float, list[Level]]] = []
    slab = _data()[0]
    for x0, levels in slabs:
        prev = out[-1] if out else None
        if (
            prev is not None
            and prev[1] == x0
            and [z for z, _, _ in prev[2]] == [z for z, _, _ in levels]
            and all(abs(a[1] - b[1]) <= MERGE and abs(a[2] - b[2]) <= MERGE for a, b in zip(prev[2], levels))
        ):
            joined = [(a[0], min(a[1], b[1]), max(a[2], b[2])) for a, b in zip(prev[2], levels)]
            out[-1] = (prev[0], x0 + slab, joined)
        else:
            out.append((x0, x0 + slab, list(levels)))
    return out


def _covers(a: Level, b: Level, m: Level) -> bool:
    """Whether the line from level a to level b contains level m, widening it by at most SIMPLIFY."""
    t = (m[0] - a[0]) / (b[0] - a[0])
    lo, hi = a[1] + t * (b[1] - a[1]), a[2] + t * (b[2] - a[2])
    return 0.0 <= m[1] - lo <= SIMPLIFY and 0.0 <= hi - m[2] <= SIMPLIFY


def simplified(run: list[Level]) -> list[Level]:
    """The run without the levels that the line between their kept neighbours contains."""
    kept = [run[0]]
    i = 0
    while i < len(run) - 1:
        j = i + 1
        while j + 1 < len(run) and all(_covers(run[i], run[j + 1], run[m]) for m in range(i + 1, j + 1)):
            j += 1
        kept.append(run[j])
        i = j
    return kept


def prism(x_lo: float, x_hi: float, run: Sequence[Level], widen: float = 0.0) -> trimesh.Trimesh:
    """The polygon (yhi up the right side, ylo down the left, counter-clockwise in y-z), ``widen`` wider on both
    sides, extruded from x_lo to x_hi."""
    pad = [-PAD] + [0.0] * (len(run) - 2) + [PAD]
    ring = [(hi + widen + PAD, z + p) for (z, _, hi), p in zip(run, pad)]
    ring += [(lo - widen - PAD, z + p) for (z, lo, _), p in zip(reversed(run), reversed(pad))]
    n, m = len(ring), len(run)
    vertices = np.array([[x, y, z] for x in (x_lo - PAD, x_hi + PAD) for y, z in ring], dtype=float)
    faces = []
    for k in range(m - 1):  # cap: a strip of trapezoids between levels k and k + 1 (right k, k+1; left n-1-k, n-2-k)
        r0, r1, l0, l1 = k, k + 1, n - 1 - k, n - 2 - k
        faces += [(n + l0, n + r0, n + r1), (n + l0, n + r1, n + l1)]  # x_hi faces +x
        faces += [(l0, r1, r0), (l0, l1, r1)]  # x_lo faces -x
    for i in range(n):  # walls
        j = (i + 1) % n
        faces += [(i, j, n + j), (i, n + j, n + i)]
    return trimesh.Trimesh(vertices, np.array(faces), process=False)


@cache
def _data() -> tuple[float, dict[str, list[tuple[float, list[Level]]]]]:
    document = json.loads(DATA.read_text())
    slices: dict[str, list[tuple[float, list[Level]]]] = {}
    for name, x0, levels in document["rows"]:
        slices.setdefault(name, []).append((float(x0), [(float(z), float(lo), float(hi)) for z, lo, hi in levels]))
    return float(document["header"]["slab"]), slices


def links() -> list[str]:
    """The links that have slices."""
    return list(_data()[1])


def slice_solid(name: str) -> trimesh.Trimesh:
    """The union of the extruded slice polygons of the vendor part ``name`` (mm)."""
    # Every other slab WIDEN wider: the 0.1 mm grid of the numbers made neighbouring slabs touch along an edge
    # (not a closed manifold once welded); offset by less than the grid, they overlap or stay apart instead.
    pieces = [
        prism(lo, hi, simplified(run), WIDEN * (k % 2))
        for k, (lo, hi, levels) in enumerate(merged(_data()[1][name]))
        for run in runs(levels)
    ]
    return trimesh.boolean.union(pieces, engine="manifold")
