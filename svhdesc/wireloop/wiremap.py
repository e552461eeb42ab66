"""Wire maps: a 4-connected wire drawn as text, one character per pixel.

``.`` free, ``#`` wire, ``S`` the wire's start, ``E`` its end; lines starting with ``#`` followed by a space
are comments. The wire must be one simple 4-connected path from S to E (every wire pixel has exactly two wire
neighbours, S and E one), and two parts of the wire that are far apart along it must not touch: a loop could not
pass between them and the objective update would jump across.
"""

from __future__ import annotations

from dataclasses import dataclass
from importlib import resources
from pathlib import Path

from svhdesc.errors import SvhdescError

FREE, WIRE, START, END = ".", "#", "S", "E"
STEPS = ((-1, 0), (1, 0), (0, -1), (0, 1))  # up, down, left, right as (row, column)
BUILTIN = ("training", "test")


@dataclass(frozen=True)
class WireMap:
    """A map of ``rows`` x ``cols`` pixels and the wire as (row, col) pixels from start to end."""

    name: str
    rows: int
    cols: int
    path: tuple[tuple[int, int], ...]

    @property
    def start(self) -> tuple[int, int]:
        return self.path[0]

    @property
    def end(self) -> tuple[int, int]:
        return self.path[-1]


def builtin_path(name: str) -> Path:
    """The file of a path shipped with the package (``training`` or ``test``)."""
    return Path(str(resources.files(__package__) / "paths" / f"{name}.txt"))


def load_map(spec: str | Path) -> WireMap:
    """Load a map file, or a built-in map by name."""
    if isinstance(spec, str) and spec in BUILTIN:
        spec = builtin_path(spec)
    path = Path(spec)
    if not path.is_file():
        raise SvhdescError(f"{path}: no such path file (built-in paths: {', '.join(BUILTIN)})")
    try:
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise SvhdescError(f"{path}: cannot read: {exc}") from None
    return parse_map(text, str(path))


def parse_map(text: str, source: str = "<map>") -> WireMap:
    grid, lines = _grid(text, source)
    rows, cols = len(grid), len(grid[0])
    wire = {(r, c) for r in range(rows) for c in range(cols) if grid[r][c] != FREE}
    starts = [(r, c) for r, c in wire if grid[r][c] == START]
    ends = [(r, c) for r, c in wire if grid[r][c] == END]
    if len(starts) != 1 or len(ends) != 1:
        raise SvhdescError(f"{source}: needs exactly one S and one E (found {len(starts)} S, {len(ends)} E)")
    path = _trace(wire, starts[0], ends[0], source, lines)
    if len(path) != len(wire):
        raise SvhdescError(f"{source}: {len(wire) - len(path)} wire pixel(s) are not on the line from S to E")
    if len(path) < 3:
        raise SvhdescError(f"{source}: the wire needs at least 3 pixels")
    _check_clearance(path, source, lines)
    return WireMap(Path(source).stem, rows, cols, tuple(path))


def _grid(text: str, source: str) -> tuple[list[str], list[int]]:
    """The map's rows (comments and blank lines left out, all as wide as the first) and their line numbers."""
    grid: list[str] = []
    lines: list[int] = []
    for number, line in enumerate(text.splitlines(), start=1):
        if line.startswith("# ") or line == "#" or not line.strip():
            continue
        row = line.rstrip()
        bad = set(row) - {FREE, WIRE, START, END}
        if bad:
            raise SvhdescError(f"{source}:{number}: unexpected character {sorted(bad)[0]!r} (use . # S E)")
        if grid and len(row) != len(grid[0]):
            raise SvhdescError(f"{source}:{number}: row has {len(row)} pixels, the first row has {len(grid[0])}")
        grid.append(row)
        lines.append(number)
    if not grid:
        raise SvhdescError(f"{source}: no map rows")
    return grid, lines


def _trace(
    wire: set[tuple[int, int]], start: tuple[int, int], end: tuple[int, int], source: str, lines: list[int]
) -> list[tuple[int, int]]:
    """The line from S to E, once every wire pixel is known to have two wire neighbours (S and E one)."""

    def neighbours(p: tuple[int, int]) -> list[tuple[int, int]]:
        return [(p[0] + dr, p[1] + dc) for dr, dc in STEPS if (p[0] + dr, p[1] + dc) in wire]

    for p in sorted(wire):
        want = 1 if p in (start, end) else 2
        if len(neighbours(p)) != want:
            raise SvhdescError(
                f"{source}:{lines[p[0]]}: wire pixel at column {p[1] + 1} has {len(neighbours(p))} wire neighbours, "
                f"needs {want} (the wire must be one 4-connected line from S to E)"
            )
    path = [start]
    previous = None
    while path[-1] != end:
        step = [n for n in neighbours(path[-1]) if n != previous]
        previous = path[-1]
        path.append(step[0])
    return path


def _check_clearance(path: list[tuple[int, int]], source: str, lines: list[int]) -> None:
    """Parts of the wire closer than 3 pixels (Chebyshev) must also be close along the wire."""
    index = {p: i for i, p in enumerate(path)}
    for i, (r, c) in enumerate(path):
        for dr in range(-2, 3):
            for dc in range(-2, 3):
                j = index.get((r + dr, c + dc))
                if j is not None and abs(j - i) > abs(dr) + abs(dc):
                    raise SvhdescError(
                        f"{source}:{lines[r]}: the wire at column {c + 1} comes within 2 pixels of another part "
                        f"of itself (at line {lines[r + dr]}, column {c + dc + 1}); leave at least 2 free pixels"
                    )
