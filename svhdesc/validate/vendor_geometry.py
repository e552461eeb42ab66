"""The vendor's visual meshes of the SVH (FZI schunk_svh_driver), per link, for comparing collision geometry with.

The vendor xacro is expanded through ``xacro/vendor/svh_hand.urdf.xacro`` with the package map pointing at the
vendor folder; each link's visual meshes are loaded with their origin and scale, in the link frame. Link frames
coincide with ours (same kinematics, same names), so a body's pose in the MJCF places its vendor mesh.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from svhdesc.errors import SvhdescError
from svhdesc.model import expand_source, load_source_mesh
from svhdesc.paths import checkout_root, source_root
from svhdesc.validate.pair import rpy_matrix

PACKAGE = "schunk_svh_driver"
SPACING = 0.5e-3  # m between surface samples; distances are refined on the exact triangles below 3 mm
REFINE_BELOW = 3e-3  # m: gaps beyond it are reported as that bound
REFINE_POINTS = 64


def default_vendor_meshes() -> Path:
    """``../shared/vendor/schunk_svh_driver`` relative to the checkout."""
    root = checkout_root() or source_root()
    return (root.parent / "shared" / "vendor" / PACKAGE).resolve()


def _floats(text: str | None, default: tuple[float, ...]) -> np.ndarray:
    return np.array([float(v) for v in text.split()]) if text and text.split() else np.array(default, dtype=float)


@dataclass
class VendorLink:
    """One link's vendor visual geometry in its link frame, with surface samples for fast distances."""

    mesh: object  # trimesh.Trimesh
    points: np.ndarray
    tree: object  # scipy cKDTree over ``points``

    def within(self, other: VendorLink, a_to_b: np.ndarray, bound: float, stride: int = 4) -> bool:
        """Whether some sample among every ``stride``-th of this surface, placed as in ``distance``, lies within
        ``bound`` of one of ``other``'s: a quick proof that the gap is at most ``bound`` (samples lie on the
        surfaces); False proves nothing. Most touching poses are settled so, without ``distance``'s full query
        (issue 14: the check's time)."""
        moved = _placed_near(self.points[::stride], other, a_to_b, bound)
        if len(moved) == 0:
            return False
        approx, _ = other.tree.query(moved, distance_upper_bound=bound)
        return bool(np.isfinite(approx).any())

    def distance(self, other: VendorLink, a_to_b: np.ndarray) -> float:
        """Gap (m) between this surface, placed in ``other``'s frame by the 4x4 ``a_to_b``, and ``other``'s;
        REFINE_BELOW for any gap at least that large."""
        import trimesh

        moved = _placed_near(self.points, other, a_to_b, REFINE_BELOW)
        if len(moved) == 0:
            return REFINE_BELOW  # at least that far apart: nothing of this part is near the other's box
        approx, _ = other.tree.query(moved, distance_upper_bound=REFINE_BELOW)
        if not np.isfinite(approx.min()):
            return REFINE_BELOW
        nearest = moved[np.argsort(approx)[:REFINE_POINTS]]
        _, exact, _ = trimesh.proximity.closest_point(other.mesh, nearest)
        return float(min(exact.min(), approx.min()))


def _placed_near(points: np.ndarray, other: VendorLink, a_to_b: np.ndarray, bound: float) -> np.ndarray:
    """``points`` moved into ``other``'s frame by ``a_to_b``, less those outside its box grown by ``bound``."""
    moved = points @ a_to_b[:3, :3].T + a_to_b[:3, 3]
    low, high = other.points.min(axis=0) - bound, other.points.max(axis=0) + bound
    return moved[np.all((moved >= low) & (moved <= high), axis=1)]


@functools.lru_cache(maxsize=4)
def vendor_links(folder: Path, side: str) -> dict[str, VendorLink]:
    """Link suffix (``virtual_j``, ``e1``, ...) -> vendor visual geometry, for a right or left hand."""
    import trimesh
    from scipy.spatial import cKDTree

    entry = source_root() / "xacro" / "vendor" / "svh_hand.urdf.xacro"
    root = expand_source(entry, {"side": side}, {PACKAGE: folder})
    prefix = f"{side}_hand_"
    links = {}
    for link in root.findall("link"):
        parts = []
        for visual in link.findall("visual"):
            mesh = visual.find("geometry/mesh")
            if mesh is None:
                continue
            filename = mesh.get("filename", "")
            if not filename.startswith(f"package://{PACKAGE}/"):
                raise SvhdescError(f"{filename}: vendor mesh outside package://{PACKAGE}")
            path = folder / filename.removeprefix(f"package://{PACKAGE}/")
            part = load_source_mesh(path, tuple(_floats(mesh.get("scale"), (1.0, 1.0, 1.0))))
            origin = visual.find("origin")
            transform = np.eye(4)
            if origin is not None:
                transform[:3, :3] = rpy_matrix(_floats(origin.get("rpy"), (0.0, 0.0, 0.0)))
                transform[:3, 3] = _floats(origin.get("xyz"), (0.0, 0.0, 0.0))
            part.apply_transform(transform)
            parts.append(part)
        if not parts:
            continue
        mesh = trimesh.util.concatenate(parts)
        count = max(500, int(mesh.area / SPACING**2))
        samples, _ = trimesh.sample.sample_surface(mesh, count, seed=0)
        points = np.vstack([samples, mesh.vertices])
        links[link.get("name").removeprefix(prefix)] = VendorLink(mesh, points, cKDTree(points))
    return links
