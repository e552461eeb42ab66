"""Running CoACD: hole closing, the fixed-seed call, re-hulling in float32, merging down to the cap."""

from __future__ import annotations

from typing import Any

import numpy as np
import trimesh

from svhdesc.compiler.decompose.params import DecompParams, DecompParamsError
from svhdesc.core.source.meshes import mesh_from_stl, stl_bytes

# --------------------------------------------------------------------------- decomposition


def _coacd() -> Any:
    # Imported lazily: the cache works without CoACD, and pool workers can cap OpenMP threads
    # before its runtime initialises.
    import coacd

    coacd.set_log_level("error")
    return coacd


def _dangling(boundary: np.ndarray, incident: dict[int, list[int]]) -> np.ndarray:
    """Boundary edges on dangling chains (an edge at a degree-1 vertex is on no loop), marked used so
    that the loop walks cannot wander into one and give up on the loop they started."""
    used = np.zeros(len(boundary), dtype=bool)
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
    return used


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
    used = _dangling(boundary, incident)
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
    src = mesh_from_stl(stl)
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
    return [mesh_from_stl(b) for b in _decompose_stl(stl_bytes(mesh), params)]
