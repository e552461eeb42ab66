"""The wire-and-loop environment of the thesis' Appendix A, as lookup tables.

Seen from above, the loop is a segment through its middle point; its two ends (the *limits*) are where the
ring crosses the wire's plane, and the ring touches the wire when a limit lands on a wire pixel. The loop turns
in 45 degree steps (4 orientations; a segment looks the same after 180 degrees), so a state holds the loop's
rotation. The map's three layers (wire, loop limits, objective) are not stored as images: everything a step needs
is precomputed once per map on a padded grid of cells (cell = row * width + column):

- ``pattern[cell]``: the wire pixels of the 5 x 5 square centred on the cell, as 25 bits;
- ``transition[(cell * 4 + rotation) * 6 + action]``: the next ``cell * 4 + rotation``, or HIT (a limit on the
  wire, or a wire pixel swept by a limit while rotating) or OUT (a limit outside the map);
- ``candidates[cell * 4 + direction]``: the objective update's candidates (see :func:`objective_candidates`).

A state is one int: ``pattern | objective_index << 25 | rotation << 30`` (objective_index 0..24 in the square).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from svhdesc.wireloop.wiremap import WireMap

ACTIONS = ("up", "down", "left", "right", "rotate_cw", "rotate_ccw")
UP, DOWN, LEFT, RIGHT, CW, CCW = range(6)
HIT, OUT = -1, -2
HALF = 2  # the state square is 5 pixels wide
ORIENTATIONS = 4  # 0, 45, 90, 135 degrees from the +column axis, counter-clockwise seen from above


def limit_offsets(radius: int, angle_deg: float) -> tuple[int, int]:
    """(row, col) of one limit of a loop of ``radius`` pixels at ``angle_deg`` (the other is the negative)."""
    a = math.radians(angle_deg)
    # Round half away from zero so that both limits stay symmetric about the middle point.
    col = math.copysign(math.floor(abs(radius * math.cos(a)) + 0.5), math.cos(a))
    row = -math.copysign(math.floor(abs(radius * math.sin(a)) + 0.5), math.sin(a))
    return int(row), int(col)


def sweep_offsets(radius: int, orientation: int) -> list[tuple[int, int]]:
    """Pixels a limit crosses turning from ``orientation`` to ``orientation + 1`` (both ends, both limits)."""
    cells: set[tuple[int, int]] = set()
    for k in range(17):
        r, c = limit_offsets(radius, 45.0 * (orientation + k / 16))
        cells.update({(r, c), (-r, -c)})
    return sorted(cells)


@dataclass(frozen=True)
class EnvConfig:
    """Everything the paper leaves open, with the values this implementation uses (see the README)."""

    loop_radius: int = 2  # pixels from the middle point to a limit (axis-aligned)
    reward_hit: float = -10.0  # a limit touches the wire
    reward_out: float = -10.0  # the loop leaves the map
    reward_lost: float = -5.0  # the objective leaves the 5-pixel square
    reward_objective: float = 10.0
    reward_done: float = 10.0  # the middle point reaches the wire's end
    reward_step: float = 0.0
    patience: int = 20  # steps without reaching an objective before an episode is cut off (the MDP's H)

    def __post_init__(self) -> None:
        if self.loop_radius not in (1, 2):
            raise ValueError("loop_radius must be 1 or 2 (the limits must lie in the 5-pixel state square)")


@dataclass(frozen=True)
class Snapshot:
    """Where an episode starts: loop middle cell, rotation, objective cell, last move, previous objective."""

    cell: int
    rotation: int
    objective: int
    direction: int
    previous: int


class Environment:
    """The precomputed tables of one map for one :class:`EnvConfig`."""

    def __init__(self, wire_map: WireMap, config: EnvConfig | None = None) -> None:
        self.map = wire_map
        self.config = config or EnvConfig()
        pad = self.pad = self.config.loop_radius + HALF + 2
        self.width = wire_map.cols + 2 * pad
        self.height = wire_map.rows + 2 * pad
        size = self.width * self.height
        wire = np.zeros(size, dtype=bool)
        self.path_cells = [self.cell(r, c) for r, c in wire_map.path]
        wire[self.path_cells] = True
        inside = np.zeros((self.height, self.width), dtype=bool)
        inside[pad : pad + wire_map.rows, pad : pad + wire_map.cols] = True
        inside = inside.ravel()
        self.wire = wire
        self.index = {cell: i for i, cell in enumerate(self.path_cells)}
        self.end = self.path_cells[-1]
        self.moves = (-self.width, self.width, -1, 1)
        self.square = [dr * self.width + dc for dr in range(-HALF, HALF + 1) for dc in range(-HALF, HALF + 1)]
        self._build_pattern(wire, inside)
        self._build_transitions(wire, inside)
        self._build_objective_index()
        self._build_candidates()

    def cell(self, row: int, col: int) -> int:
        return (row + self.pad) * self.width + col + self.pad

    def row_col(self, cell: int) -> tuple[int, int]:
        return cell // self.width - self.pad, cell % self.width - self.pad

    def _interior(self) -> np.ndarray:
        """Cells whose 5 x 5 square and loop sweep stay inside the padded grid."""
        margin = self.config.loop_radius + HALF
        grid = np.zeros((self.height, self.width), dtype=bool)
        grid[margin : self.height - margin, margin : self.width - margin] = True
        return np.flatnonzero(grid)

    def _build_pattern(self, wire: np.ndarray, inside: np.ndarray) -> None:
        cells = self._interior()
        bits = np.zeros(cells.size, dtype=np.int64)
        for i, offset in enumerate(self.square):
            bits |= wire[cells + offset].astype(np.int64) << i
        pattern = np.zeros(wire.size, dtype=np.int64)
        pattern[cells] = bits
        self.pattern: list[int] = pattern.tolist()

    def _build_transitions(self, wire: np.ndarray, inside: np.ndarray) -> None:
        radius = self.config.loop_radius
        w = self.width
        cells = self._interior()
        limits = [limit_offsets(radius, 45.0 * k) for k in range(ORIENTATIONS)]
        limit_flat = [r * w + c for r, c in limits]
        # hit[k] / out[k]: a loop in orientation k centred on each cell touches the wire / leaves the map.
        hit = np.zeros((ORIENTATIONS, wire.size), dtype=bool)
        out = np.ones((ORIENTATIONS, wire.size), dtype=bool)
        for k, off in enumerate(limit_flat):
            hit[k, cells] = wire[cells + off] | wire[cells - off]
            out[k, cells] = ~(inside[cells + off] & inside[cells - off] & inside[cells])
        # swept[k]: turning between orientation k and k + 1 crosses a wire pixel.
        swept = np.zeros((ORIENTATIONS, wire.size), dtype=bool)
        for k in range(ORIENTATIONS):
            for r, c in sweep_offsets(radius, k):
                swept[k, cells] |= wire[cells + r * w + c]
        table = np.full((wire.size, ORIENTATIONS, 6), OUT, dtype=np.int64)
        for k in range(ORIENTATIONS):
            for action, move in enumerate(self.moves):
                target = cells + move
                code = np.where(hit[k, target], HIT, target * 4 + k)
                table[cells, k, action] = np.where(out[k, target], OUT, code)
            for action, new, sweep in ((CW, (k - 1) % 4, (k - 1) % 4), (CCW, (k + 1) % 4, k)):
                code = np.where(hit[new, cells] | swept[sweep, cells], HIT, cells * 4 + new)
                table[cells, k, action] = np.where(out[new, cells], OUT, code)
        self.transition: list[int] = table.ravel().tolist()

    def _build_objective_index(self) -> None:
        # Objective cell minus middle cell -> index in the 5 x 5 square, or -1 outside it. A move shifts the
        # difference by one pixel, so +-3 rows and columns cover every case the environment meets.
        w = self.width
        self.objective_offset = 3 * w + 3
        table = [-1] * (2 * self.objective_offset + 1)
        for i, offset in enumerate(self.square):
            table[offset + self.objective_offset] = i
        self.objective_index = table

    def _build_candidates(self) -> None:
        self.candidates: dict[int, list[tuple[int, int]]] = {}
        for cell in self.path_cells:
            for direction in range(4):
                self.candidates[cell * 4 + direction] = objective_candidates(self, cell, direction)

    def state(self, cell: int, rotation: int, objective: int) -> int:
        rel = self.objective_index[objective - cell + self.objective_offset]
        return self.pattern[cell] | rel << 25 | rotation << 30

    def next_objective(self, cell: int, direction: int, objective: int, previous: int) -> int:
        """The objective update at ``cell`` reached by moving in ``direction``.

        Ties in distance go to the candidate farther from the ``previous`` objective, then to the lower cell.
        With no candidate left (e.g. arriving backwards at the wire's start) the objective stays where it is.
        """
        options = self.candidates.get(cell * 4 + direction) or objective_candidates(self, cell, direction)
        if not options:
            return objective
        return max(options, key=lambda o: (self.distance2(o, objective), self.distance2(o, previous), -o))

    def distance2(self, a: int, b: int) -> int:
        (ra, ca), (rb, cb) = self.row_col(a), self.row_col(b)
        return (ra - rb) ** 2 + (ca - cb) ** 2

    def start(self) -> Snapshot:
        """The loop around the wire's start, turned across the wire's first run, objective placed by the rule."""
        first = self.path_cells[1] - self.path_cells[0]
        direction = self.moves.index(first)
        rotation = 2 if direction in (LEFT, RIGHT) else 0
        cell = self.path_cells[0]
        return Snapshot(cell, rotation, self.next_objective(cell, direction, cell, cell), direction, cell)

    def progress(self, cell: int) -> int:
        """Index along the wire of a wire cell (0 at the start)."""
        return self.index[cell]


def objective_candidates(env: Environment, cell: int, direction: int) -> list[int]:
    """The objective update (paper, section III-C), before picking the farthest.

    Candidates: the points of the cross through the middle point within the 5-pixel square; keep those on the
    wire; drop those on the side opposite to the last direction of motion.
    """
    opposite = {UP: DOWN, DOWN: UP, LEFT: RIGHT, RIGHT: LEFT}[direction]
    out = []
    for move_index, move in enumerate(env.moves):
        if move_index == opposite:
            continue
        for step in range(1, HALF + 1):
            target = cell + step * move
            if env.wire[target]:
                out.append(target)
    return out
