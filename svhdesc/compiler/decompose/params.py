"""CoACD parameters (plus the per-hull vertex bound) and the presets per link class."""

from __future__ import annotations

import dataclasses
import json
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np

from svhdesc.errors import SvhdescError

_PREPROCESS_MODES = ("auto", "on", "off")
MAX_PREPROCESS_RESOLUTION = 1000  # CoACD's: above it, 'this is probably a bug' and std::terminate


class DecompParamsError(SvhdescError, ValueError):
    """Invalid decomposition parameters (a ValueError, and a one-line CLI error)."""


@dataclass(frozen=True)
class DecompParams:
    """CoACD settings plus the per-hull vertex bound.  Defaults: the phalanx preset below."""

    threshold: float = 0.1  # concavity threshold; higher -> fewer, looser hulls
    max_convex_hull: int = 4  # hull cap per mesh (CoACD merges down to it); -1 = no cap
    preprocess_mode: Literal["auto", "on", "off"] = "auto"  # manifold remesh (auto: if non-manifold)
    preprocess_resolution: int = 30  # grid of that remesh: coarser closes bigger gaps, inflates more
    resolution: int = 2000  # samples for the concavity metric
    # Tree search width/iterations/depth, far below CoACD's 20/150/3: with a hull cap the merge
    # step decides the result, and the wider search only costs time (numbers in the report).
    mcts_nodes: int = 10
    mcts_iterations: int = 30
    mcts_max_depth: int = 2
    seed: int = 0
    max_hull_vertices: int = 48  # bound on vertices per hull (CoACD decimate + our own fallback)
    # Fan-fill open boundary loops first: CoACD's voxel remesh of an open mesh leaks through the
    # holes and yields a hollow shell (vendor palm: hulls then cover only 53-80 % of its volume).
    close_holes: bool = True

    def __post_init__(self) -> None:
        # Coerce ints to float so 1 and 1.0 give the same canonical JSON (and cache key).
        if isinstance(self.threshold, bool) or not isinstance(self.threshold, (int, float)):
            raise DecompParamsError(f"decomposition parameter 'threshold' must be a number, got {self.threshold!r}")
        object.__setattr__(self, "threshold", float(self.threshold))
        if not 0.0 < self.threshold <= 1.0:
            raise DecompParamsError(f"decomposition parameter 'threshold' must be in (0, 1], got {self.threshold}")
        for name, low in (
            ("max_convex_hull", -1),
            ("preprocess_resolution", 1),
            ("resolution", 1),
            ("mcts_nodes", 1),
            ("mcts_iterations", 1),
            ("mcts_max_depth", 1),
            ("seed", 0),
            ("max_hull_vertices", 4),
        ):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
                raise DecompParamsError(f"decomposition parameter {name!r} must be an integer, got {value!r}")
            object.__setattr__(self, name, int(value))
            if value < low:
                raise DecompParamsError(f"decomposition parameter {name!r} must be >= {low}, got {value}")
        if self.preprocess_resolution > MAX_PREPROCESS_RESOLUTION:  # CoACD aborts the process above it
            raise DecompParamsError(
                f"decomposition parameter 'preprocess_resolution' must be <= {MAX_PREPROCESS_RESOLUTION} "
                f"(CoACD's limit), got {self.preprocess_resolution}"
            )
        if self.max_convex_hull == 0:
            raise DecompParamsError("decomposition parameter 'max_convex_hull' must be >= 1 or -1 (no cap)")
        if self.seed >= 2**32:
            raise DecompParamsError(f"decomposition parameter 'seed' must fit in 32 bits, got {self.seed}")
        if not isinstance(self.close_holes, bool):
            raise DecompParamsError(
                f"decomposition parameter 'close_holes' must be true or false, got {self.close_holes!r}"
            )
        if self.preprocess_mode not in _PREPROCESS_MODES:
            raise DecompParamsError(
                f"decomposition parameter 'preprocess_mode' must be one of {_PREPROCESS_MODES}, "
                f"got {self.preprocess_mode!r}"
            )

    @classmethod
    def from_mapping(cls, d: Mapping[str, Any], base: DecompParams | None = None) -> DecompParams:
        """Build from a config mapping; keys not given keep ``base``'s values (default: defaults)."""
        known = {f.name for f in dataclasses.fields(cls)}
        for key in d:
            if key not in known:
                raise DecompParamsError(f"unknown decomposition parameter {key!r} (known: {', '.join(sorted(known))})")
        return dataclasses.replace(base or cls(), **dict(d))

    def to_json(self) -> str:
        """Canonical JSON: sorted keys, no whitespace; part of the cache key."""
        return json.dumps(dataclasses.asdict(self), sort_keys=True, separators=(",", ":"))


# Presets per link class, measured on the vendor meshes as loaded by svhdesc.core.source.meshes (2 cores,
# one job at a time).  "excess" = hull volume outside the mesh / mesh volume; "cover" = share of
# the mesh inside the hulls; a single convex hull is the reference.
#   palm      h10, h11    5.4, 6.4 s   8 hulls  excess 0.39, 0.48 (one hull 0.73, 0.76)  cover 98, 97 %
#   phalanx   f11,f12,d11 2.1-4.9 s  2-4 hulls  excess 0.17, 0.60, 0.05 (1.65 for f12's hull)
#   fingertip f13, d13    3.6, 2.9 s   4 hulls  excess 0.23, 0.17 (one hull 0.42, 0.28)    cover 99 %
#   arm       UR5 links   0.6-8.0 s  2-6 hulls  excess 0.02-0.33 (forearm 0.17 vs 0.55 one hull)
# CoACD's own defaults take 135 s / 93 hulls on h10 and cover only 53 % of it (open mesh: hollow).
LINK_CLASS_PARAMS: dict[str, DecompParams] = {
    "palm": DecompParams(threshold=0.15, max_convex_hull=8, max_hull_vertices=48),
    "phalanx": DecompParams(),
    "fingertip": DecompParams(max_hull_vertices=64),  # contact surface: keep the shape finer
    "arm": DecompParams(max_convex_hull=6, max_hull_vertices=64),
}
