"""Convex decomposition of collision meshes with CoACD, behind a content-addressed cache.

CoACD is slow (tens of seconds for the vendor palm at its defaults) and every extra hull slows
the simulation, so the build decomposes each mesh once per (mesh, parameters, CoACD version) and
serves every later build from ``HullCache``.  Results are a pure function of the cache key:

* the input is canonicalised first (``meshes.stl_bytes``: float32 triangles in a canonical order,
  then identical vertices merged), so two meshes with the same key are decomposed from the same
  bytes, whatever their vertex and face order;
* CoACD runs with a fixed seed (it is reproducible on one machine, whatever its thread count);
* every part is re-hulled from float32 points, so the hull survives the STL round trip of the
  cache bit for bit, and the returned meshes are always parsed back from those bytes.
"""

from __future__ import annotations

import concurrent.futures
import dataclasses
import hashlib
import importlib.metadata
import json
import multiprocessing
import os
import shutil
import sys
import tempfile
import warnings
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal

import numpy as np
import trimesh

from svhdesc.errors import SvhdescError
from svhdesc.meshes import mesh_from_stl, stl_bytes

__all__ = [
    "LINK_CLASS_PARAMS",
    "bounded_hull",
    "DecompParams",
    "DecompParamsError",
    "HullCache",
    "cache_key",
    "cached_decompose",
    "decompose",
    "decompose_calls",
    "parallel_decompose",
]

# Bump when anything in the post-processing below changes its output: it is part of every key,
# so stale cache entries simply stop matching.
_ALGORITHM_VERSION = "svhdesc.decompose/1"
_PREPROCESS_MODES = ("auto", "on", "off")

# CoACD runs started by (or on behalf of) this process: in-process calls of `decompose` plus jobs
# that `parallel_decompose` ships to worker processes.  Tests use it to prove a cache hit ran none.
decompose_calls = 0


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


# Presets per link class, measured on the vendor meshes as loaded by svhdesc.meshes (2 cores,
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


# --------------------------------------------------------------------------- STL canonical form


# Kept under its old name for callers and tests: the codec lives in svhdesc.meshes.
_mesh_from_stl = mesh_from_stl


def cache_key(mesh: trimesh.Trimesh, params: DecompParams) -> str:
    """sha256 over the input's canonical STL, the params' canonical JSON and the CoACD version."""
    return _key_from_stl(stl_bytes(mesh), params)


def _key_from_stl(stl: bytes, params: DecompParams) -> str:
    h = hashlib.sha256()
    # Length-prefixed fields, so no two different inputs can concatenate to the same stream.
    for part in (_ALGORITHM_VERSION.encode(), _coacd_version().encode(), params.to_json().encode(), stl):
        h.update(len(part).to_bytes(8, "little"))
        h.update(part)
    return h.hexdigest()


def _coacd_version() -> str:
    try:
        return importlib.metadata.version("coacd")
    except importlib.metadata.PackageNotFoundError:
        return "unknown"


# --------------------------------------------------------------------------- decomposition


def _coacd() -> Any:
    # Imported lazily: the cache works without CoACD, and pool workers can cap OpenMP threads
    # before its runtime initialises.
    import coacd

    coacd.set_log_level("error")
    return coacd


def _close_holes(vertices: np.ndarray, faces: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Drop index-degenerate faces and cap every closed boundary loop with a fan to its centroid.

    Not a faithful repair (a fan over a non-planar hole may cut the surface); it only has to
    make the surface closed at CoACD's voxel scale, so its remesh sees a solid, not a shell.
    Each fan triangle reverses its boundary edge, so a consistently wound mesh stays consistent
    (and, if the holes were its only defect, becomes watertight and skips the remesh).
    """
    faces = faces[(faces[:, 0] != faces[:, 1]) & (faces[:, 1] != faces[:, 2]) & (faces[:, 2] != faces[:, 0])]
    directed = faces[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2)
    _, inverse, counts = np.unique(np.sort(directed, axis=1), axis=0, return_inverse=True, return_counts=True)
    boundary = directed[counts[inverse.reshape(-1)] == 1]  # edges of exactly one face, as wound there
    if len(boundary) == 0:
        return vertices, faces
    incident: dict[int, list[int]] = {}
    for i, (a, b) in enumerate(boundary.tolist()):
        incident.setdefault(a, []).append(i)
        incident.setdefault(b, []).append(i)
    used = np.zeros(len(boundary), dtype=bool)
    # Prune dangling chains (an edge at a degree-1 vertex is on no loop), so the walks below
    # cannot wander into one and give up on the loop they started.
    degree = {v: len(es) for v, es in incident.items()}
    stack = [v for v, d in degree.items() if d == 1]
    while stack:
        for e in incident[stack.pop()]:
            if not used[e]:
                used[e] = True
                for w in boundary[e].tolist():
                    degree[w] -= 1
                    if degree[w] == 1:
                        stack.append(w)
    new_vertices, new_faces = [vertices], [faces]
    centre = len(vertices)
    for first in range(len(boundary)):
        if used[first]:
            continue
        used[first] = True
        start, cur = boundary[first].tolist()
        loop = [first]
        while cur != start:
            free = [e for e in incident[cur] if not used[e]]
            if not free:
                break
            # Follow the loop's own direction (a->b, b->c) where the winding allows it.
            nxt = next((e for e in free if boundary[e][0] == cur), free[0])
            used[nxt] = True
            loop.append(nxt)
            a, b = boundary[nxt].tolist()
            cur = b if a == cur else a
        if cur != start or len(loop) < 3:
            continue
        edges = boundary[loop]
        new_vertices.append(vertices[np.unique(edges)].mean(axis=0, keepdims=True))
        new_faces.append(np.column_stack([edges[:, 1], edges[:, 0], np.full(len(edges), centre)]))
        centre += 1
    return np.vstack(new_vertices), np.vstack(new_faces)


def _farthest_points(points: np.ndarray, k: int) -> np.ndarray:
    """k points by farthest-point sampling; deterministic (start: farthest from the mean)."""
    dist = np.linalg.norm(points - points.mean(axis=0), axis=1)
    chosen = [int(np.argmax(dist))]
    dist = np.linalg.norm(points - points[chosen[0]], axis=1)
    for _ in range(1, k):
        nxt = int(np.argmax(dist))
        chosen.append(nxt)
        dist = np.minimum(dist, np.linalg.norm(points - points[nxt], axis=1))
    return points[np.sort(chosen)]


def _hull(points: np.ndarray, max_vertices: int) -> trimesh.Trimesh | None:
    """Convex hull of float32-representable points with at most max_vertices; None if flat."""
    pts = np.unique(np.asarray(points, dtype=np.float32).astype(np.float64), axis=0)
    if len(pts) < 4:
        return None
    with np.errstate(divide="ignore", invalid="ignore"):  # flat input: trimesh divides by 0 volume
        return _hull_checked(pts, max_vertices)


def _hull_checked(pts: np.ndarray, max_vertices: int) -> trimesh.Trimesh | None:
    try:
        hull = trimesh.convex.convex_hull(pts)
        if len(hull.vertices) > max_vertices:
            # Too many corners for the simulator: re-hull a well-spread subset (slightly inside).
            hull = trimesh.convex.convex_hull(_farthest_points(np.asarray(hull.vertices), max_vertices))
    except Exception:  # qhull raises on coplanar/degenerate input even after joggling
        return None
    extent = float(np.max(hull.extents))
    if not hull.is_watertight or not extent > 0 or hull.volume <= 1e-9 * extent**3:
        return None
    return hull


def bounded_hull(mesh: trimesh.Trimesh, max_vertices: int) -> trimesh.Trimesh:
    """One convex hull of the mesh with at most ``max_vertices`` corners (the single-hull mode)."""
    hull = _hull(np.asarray(mesh.vertices), max_vertices)
    if hull is None:
        raise DecompParamsError("cannot hull a flat or empty mesh")
    return hull


def _merge_to_cap(hulls: list[trimesh.Trimesh], cap: int, max_vertices: int) -> list[trimesh.Trimesh]:
    """Greedy fallback if CoACD returns more than the cap: merge the pair that adds least volume."""
    hulls = list(hulls)
    while len(hulls) > cap:
        best: tuple[float, int, int, trimesh.Trimesh] | None = None
        for i in range(len(hulls)):
            for j in range(i + 1, len(hulls)):
                merged = _hull(np.vstack([hulls[i].vertices, hulls[j].vertices]), max_vertices)
                if merged is None:
                    continue
                growth = merged.volume - hulls[i].volume - hulls[j].volume
                if best is None or growth < best[0]:
                    best = (growth, i, j, merged)
        if best is None:
            break
        _, i, j, merged = best
        hulls = [h for n, h in enumerate(hulls) if n not in (i, j)] + [merged]
    return hulls


def _sort_key(hull_stl: tuple[trimesh.Trimesh, bytes]) -> tuple[Any, ...]:
    hull, stl = hull_stl
    # Centroid (rounded so float noise cannot reorder), then volume, then the bytes as tie-break.
    return (*np.round(hull.center_mass, 9).tolist(), round(float(hull.volume), 15), stl)


def _decompose_stl(stl: bytes, params: DecompParams) -> list[bytes]:
    """Decompose a canonical STL; returns the hulls' canonical STL bytes in deterministic order."""
    src = _mesh_from_stl(stl)
    if len(src.faces) == 0:
        raise ValueError("cannot decompose an empty mesh")
    vertices = np.asarray(src.vertices, dtype=np.float64)
    faces = np.asarray(src.faces, dtype=np.int64)
    if params.close_holes:
        vertices, faces = _close_holes(vertices, faces)
    coacd = _coacd()
    parts = coacd.run_coacd(
        coacd.Mesh(vertices, faces.astype(np.int32)),
        threshold=params.threshold,
        max_convex_hull=params.max_convex_hull,
        preprocess_mode=params.preprocess_mode,
        preprocess_resolution=params.preprocess_resolution,
        resolution=params.resolution,
        mcts_nodes=params.mcts_nodes,
        mcts_iterations=params.mcts_iterations,
        mcts_max_depth=params.mcts_max_depth,
        merge=True,  # required for max_convex_hull to take effect
        decimate=True,  # lets CoACD honour max_ch_vertex itself; _hull enforces it regardless
        max_ch_vertex=params.max_hull_vertices,
        seed=params.seed,
    )
    # Re-hull every part: CoACD's parts are hulls, but winding/convexity is not guaranteed after
    # float32 rounding, and flat slivers (zero volume) break simulators, so they are dropped.
    hulls = [h for h in (_hull(v, params.max_hull_vertices) for v, _ in parts) if h is not None]
    if not hulls:
        # Everything degenerate (e.g. a thin plate at coarse resolution): one hull of the lot.
        whole = _hull(src.vertices, params.max_hull_vertices)
        if whole is None:
            raise ValueError("mesh has no volume: cannot build a convex hull")
        hulls = [whole]
    if params.max_convex_hull > 0 and len(hulls) > params.max_convex_hull:
        hulls = _merge_to_cap(hulls, params.max_convex_hull, params.max_hull_vertices)
    blobs = [(h, stl_bytes(h)) for h in hulls]
    return [stl for _, stl in sorted(blobs, key=_sort_key)]


def decompose(mesh: trimesh.Trimesh, params: DecompParams) -> list[trimesh.Trimesh]:
    """Convex decomposition of ``mesh``: convex, outward-wound hulls in a deterministic order,
    each with at most ``params.max_hull_vertices`` vertices.  Always runs CoACD (no cache)."""
    global decompose_calls
    decompose_calls += 1
    return [_mesh_from_stl(b) for b in _decompose_stl(stl_bytes(mesh), params)]


# --------------------------------------------------------------------------- cache


class HullCache:
    """Content-addressed store: ``<root>/<key>/hull_000.stl ... entry.json``.

    Entries are written into a temporary sibling directory and renamed into place, so readers
    never see a half-written entry; anything that fails validation later (truncated file, edited
    JSON, missing hull, e.g. after a crash before the data hit the disk) is deleted and reported
    as a miss, so no fsync is needed for correctness.
    """

    ENTRY = "entry.json"
    FORMAT = 1

    def __init__(self, root: Path | str) -> None:
        self.root = Path(root)
        self.broken = ""  # why writing failed: a cache that cannot be written is not used for writing again

    def store(self, key: str, hull_stl_bytes: list[bytes], meta: Mapping[str, Any] | None = None) -> None:
        """``put`` for a build: a read-only, full or misplaced cache warns once and the build goes on."""
        if self.broken:
            return
        try:
            self.put(key, hull_stl_bytes, meta)
        except OSError as exc:
            self.broken = exc.strerror or type(exc).__name__
            warnings.warn(f"hull cache {self.root} is unusable ({self.broken}); building without caching", stacklevel=2)

    def meshes(self, key: str) -> list[trimesh.Trimesh] | None:
        """The entry parsed into meshes, or None; an entry that does not parse is deleted (rebuilt)."""
        try:
            blobs = self.get(key)
        except OSError:
            return None
        if blobs is None:
            return None
        try:
            return [_mesh_from_stl(b) for b in blobs]
        except ValueError:
            shutil.rmtree(self.path(key), ignore_errors=True)
            return None

    @staticmethod
    def key(mesh: trimesh.Trimesh, params: DecompParams) -> str:
        return cache_key(mesh, params)

    def path(self, key: str) -> Path:
        # Keys are sha256 hex digests; anything else could escape root.
        if len(key) != 64 or any(c not in "0123456789abcdef" for c in key):
            raise ValueError(f"invalid cache key {key!r}")
        return self.root / key

    @staticmethod
    def _name(i: int) -> str:
        return f"hull_{i:03d}.stl"

    def get(self, key: str) -> list[bytes] | None:
        """The entry's hull STL bytes, or None on a miss (a corrupt/partial entry is deleted)."""
        entry = self.path(key)
        if not entry.is_dir():
            return None
        blobs = self._read_valid(entry, key)
        if blobs is None:
            shutil.rmtree(entry, ignore_errors=True)
        return blobs

    def _read_valid(self, entry: Path, key: str) -> list[bytes] | None:
        try:
            meta = json.loads((entry / self.ENTRY).read_text(encoding="utf-8"))
            files = meta["files"]
            count = meta["count"]
            if (
                meta.get("format") != self.FORMAT
                or meta.get("key") != key
                or not isinstance(count, int)
                or count < 1
                or not isinstance(files, list)
                or len(files) != count
            ):
                return None
            blobs = []
            for i, item in enumerate(files):
                if item["name"] != self._name(i):
                    return None
                data = (entry / item["name"]).read_bytes()
                if hashlib.sha256(data).hexdigest() != item["sha256"]:
                    return None
                blobs.append(data)
            return blobs
        except (OSError, ValueError, KeyError, TypeError, AttributeError):  # JSONDecodeError: ValueError
            return None

    def put(self, key: str, hull_stl_bytes: list[bytes], meta: Mapping[str, Any] | None = None) -> Path:
        """Store (or replace) an entry atomically; ``meta`` is kept in entry.json for humans."""
        if not hull_stl_bytes:
            raise ValueError("refusing to cache an empty hull list")
        final = self.path(key)
        self.root.mkdir(parents=True, exist_ok=True)
        tmp = Path(tempfile.mkdtemp(prefix=f".{key[:16]}.", suffix=".tmp", dir=self.root))
        try:
            files = []
            for i, data in enumerate(hull_stl_bytes):
                (tmp / self._name(i)).write_bytes(data)
                files.append({"name": self._name(i), "sha256": hashlib.sha256(data).hexdigest()})
            entry = {"format": self.FORMAT, "key": key, "count": len(files), "files": files}
            if meta:
                entry["meta"] = dict(meta)
            (tmp / self.ENTRY).write_text(json.dumps(entry, indent=1, sort_keys=True) + "\n", encoding="utf-8")
            try:
                os.replace(tmp, final)
            except OSError:
                # POSIX cannot rename onto a non-empty directory: move the old entry aside first.
                # A reader in between sees no entry (a miss), never a mix of old and new files.
                trash = Path(tempfile.mkdtemp(prefix=f".{key[:16]}.", suffix=".old", dir=self.root))
                try:
                    os.replace(final, trash / "entry")
                except FileNotFoundError:
                    pass  # a concurrent get() deleted it meanwhile
                os.replace(tmp, final)
                shutil.rmtree(trash, ignore_errors=True)
        except BaseException:
            shutil.rmtree(tmp, ignore_errors=True)
            raise
        return final


def _entry_meta(params: DecompParams) -> dict[str, Any]:
    return {
        "params": dataclasses.asdict(params),
        "coacd": _coacd_version(),
        "algorithm": _ALGORITHM_VERSION,
    }


def cached_decompose(
    mesh: trimesh.Trimesh,
    params: DecompParams,
    cache: HullCache | None,
    force: bool = False,
) -> tuple[list[trimesh.Trimesh], bool]:
    """``decompose`` through the cache: (hulls, cache_hit).  ``force`` recomputes and overwrites.

    Hits and misses return identical meshes: both are parsed from the same STL bytes.
    """
    global decompose_calls
    stl = stl_bytes(mesh)
    key = _key_from_stl(stl, params)
    if cache is not None and not force:
        hit = cache.meshes(key)
        if hit is not None:
            return hit, True
    decompose_calls += 1
    blobs = _decompose_stl(stl, params)
    if cache is not None:
        cache.store(key, blobs, _entry_meta(params))
    return [_mesh_from_stl(b) for b in blobs], False


# --------------------------------------------------------------------------- parallel


def _init_worker(parent: int = 0) -> None:
    # One OpenMP thread per worker: the pool already fills the cores, and oversubscribing them
    # only slows every job.  Works because the worker imports CoACD lazily, after this.
    os.environ["OMP_NUM_THREADS"] = "1"
    die_with_parent(parent)


PR_SET_PDEATHSIG = 1


def die_with_parent(parent: int) -> None:
    """Linux: the kernel sends SIGKILL to this process when its parent dies (even by kill -9)."""
    if not sys.platform.startswith("linux"):
        return
    import ctypes
    import signal

    libc = ctypes.CDLL(None, use_errno=True)
    libc.prctl(PR_SET_PDEATHSIG, int(signal.SIGKILL), 0, 0, 0)
    if parent and os.getppid() != parent:  # the parent died before prctl took effect
        os._exit(1)


class _Progress:
    """A one-line progress bar on stderr (the caller decides whether stderr is a terminal)."""

    def __init__(self, total: int, enabled: bool, width: int = 30) -> None:
        self.total, self.enabled, self.width, self.done = total, enabled, width, 0

    def step(self, label: str) -> None:
        self.done += 1
        if not self.enabled or self.total == 0:
            return
        filled = self.width * self.done // self.total
        bar = "#" * filled + "-" * (self.width - filled)
        sys.stderr.write(f"\rdecompose [{bar}] {self.done}/{self.total} {label[:40]:<40}")
        if self.done == self.total:
            sys.stderr.write("\n")
        sys.stderr.flush()


def parallel_decompose(
    jobs: list[tuple[str, trimesh.Trimesh, DecompParams]],
    cache: HullCache | None,
    n_jobs: int,
    force: bool = False,
    progress: bool = False,
) -> dict[str, tuple[list[trimesh.Trimesh], bool]]:
    """Decompose many meshes: hits come from the cache, misses run in ``n_jobs`` processes.

    Returns ``{name: (hulls, cache_hit)}`` in job order.  Results do not depend on ``n_jobs``
    (each is a function of its key alone); jobs with equal keys are decomposed once.
    ``n_jobs <= 0`` means one process per CPU; 1 runs in this process without a pool.  Workers
    are spawned, so a calling script needs the usual ``if __name__ == "__main__":`` guard.
    """
    global decompose_calls
    names = [name for name, _, _ in jobs]
    if len(set(names)) != len(names):
        dupes = sorted({n for n in names if names.count(n) > 1})
        raise ValueError(f"duplicate job names: {', '.join(dupes)}")

    results: dict[str, tuple[list[trimesh.Trimesh], bool]] = {}
    pending: dict[str, tuple[bytes, DecompParams, list[str]]] = {}  # key -> (stl, params, names)
    bar = _Progress(len(jobs), progress)
    for name, mesh, params in jobs:
        stl = stl_bytes(mesh)
        key = _key_from_stl(stl, params)
        if key in pending:
            pending[key][2].append(name)
            continue
        hit = None if cache is None or force else cache.meshes(key)
        if hit is not None:
            results[name] = (hit, True)
            bar.step(f"{name} (cached)")
        else:
            pending[key] = (stl, params, [name])

    def finish(key: str, blobs: list[bytes]) -> None:
        _, params, job_names = pending[key]
        if cache is not None:
            cache.store(key, blobs, _entry_meta(params))
        for job_name in job_names:
            results[job_name] = ([_mesh_from_stl(b) for b in blobs], False)
            bar.step(job_name)

    workers = n_jobs if n_jobs > 0 else (os.cpu_count() or 1)
    workers = min(workers, len(pending))
    if workers <= 1:
        for key, (stl, params, job_names) in pending.items():
            decompose_calls += 1
            finish(key, _run_job(job_names[0], stl, params))
    elif pending:
        # spawn, not fork: CoACD's OpenMP/TBB runtimes are not fork-safe once initialised.
        ctx = multiprocessing.get_context("spawn")
        with concurrent.futures.ProcessPoolExecutor(
            workers, mp_context=ctx, initializer=_init_worker, initargs=(os.getpid(),)
        ) as pool:
            futures = {}
            for key, (stl, params, job_names) in pending.items():
                decompose_calls += 1
                futures[pool.submit(_run_job, job_names[0], stl, params)] = key
            try:
                for fut in concurrent.futures.as_completed(futures):
                    finish(futures[fut], fut.result())
            except BaseException:
                for fut in futures:
                    fut.cancel()
                raise
    return {name: results[name] for name in names}


def _run_job(name: str, stl: bytes, params: DecompParams) -> list[bytes]:
    try:
        return _decompose_stl(stl, params)
    except Exception as exc:
        raise RuntimeError(f"convex decomposition of {name!r} failed: {exc}") from exc
