"""Whether a set of convex hulls can be a decomposition of a mesh: the check every reused hull passes.

A CoACD decomposition cuts the mesh into pieces and hulls each, so its hulls cover the mesh and lie inside the
mesh's own convex hull; CoACD's remesh (``preprocess_mode``) moves the surface by a fraction of a voxel. Measured
on every shipped decomposition (``tests/compiler/decompose/test_fit.py`` runs them all): no mesh point lies more
than 4.1 % of the mesh's largest extent outside its hulls, no hull corner more than 0.93 % outside the mesh's
convex hull; a box over a mesh's bounds, or its oriented bounding box, reaches 10 % to 40 % beyond it.

What this cannot tell apart is a decomposition of a *nearly identical* mesh: the SVH's fingertips ``s`` and ``t``
differ by 0.5 mm, less than CoACD's own distance from either mesh, so each one's hulls pass as the other's. That
is the hull cache's trust boundary (docs/build.md): ``build --check`` decomposes afresh unless told to trust
the cache.
"""

from __future__ import annotations

import numpy as np
import trimesh

COVER_TOLERANCE = 0.06  # of the mesh's largest extent: how far a mesh point may lie outside every hull
INSIDE_TOLERANCE = 0.03  # of the largest extent: how far a hull corner may lie outside the mesh's convex hull


def outside(points: np.ndarray, hulls: list[trimesh.Trimesh]) -> np.ndarray:
    """How far each point lies outside the union of convex ``hulls`` (0 inside one): the largest distance to a
    face plane of the nearest hull, a lower bound of the true distance."""
    points = np.asarray(points, dtype=float)
    best = np.full(len(points), np.inf)
    left = np.arange(len(points))  # points not yet inside a hull: the only ones the next hull must test
    for hull in hulls:
        normals = np.asarray(hull.face_normals, dtype=float)
        offsets = np.einsum("ij,ij->i", normals, np.asarray(hull.triangles[:, 0], dtype=float))
        distance = np.maximum((points[left] @ normals.T - offsets).max(axis=1), 0.0)
        best[left] = np.minimum(best[left], distance)
        left = left[best[left] > 0.0]
    return best


def misfit_hulls(mesh: trimesh.Trimesh, hulls: list[trimesh.Trimesh]) -> str:
    """Why ``hulls`` cannot be a decomposition of ``mesh`` ("" if they can): they reach beyond its convex hull, or
    leave part of it uncovered (the cheaper test first)."""
    if not hulls:
        return "it holds no hull"
    extent = float(np.max(mesh.extents))
    corners = np.vstack([np.asarray(h.vertices) for h in hulls])
    beyond = float(outside(corners, [mesh.convex_hull]).max())
    if beyond > INSIDE_TOLERANCE * extent:
        return (
            f"its hulls reach {beyond:.4g} m beyond the mesh's convex hull "
            f"(more than {INSIDE_TOLERANCE:.0%} of its {extent:.4g} m extent)"
        )
    uncovered = float(outside(np.asarray(mesh.vertices), hulls).max())
    if uncovered > COVER_TOLERANCE * extent:
        return (
            f"its hulls leave the mesh uncovered by {uncovered:.4g} m "
            f"(more than {COVER_TOLERANCE:.0%} of its {extent:.4g} m extent)"
        )
    return ""
