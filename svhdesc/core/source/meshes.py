"""Mesh conversion for the build: load sources (COLLADA, STL, OBJ), bake scales, write canonical STL.

Everything returned is in metres, in the frame the source file describes (COLLADA node
transforms, ``<unit>`` and ``<up_axis>`` applied), with duplicate vertices merged.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import trimesh
from lxml import etree

from svhdesc.core import exact
from svhdesc.core.limits import MAX_MESH_TRIANGLES, mesh_size_problem
from svhdesc.core.source.winding import fix_winding

MAX_RAW = 1e6  # largest plausible number in a mesh file (a coordinate of 1 km in millimetres)
MAX_METRES = 1e3  # largest plausible coordinate in metres
MERGE_DIGITS = 6  # vertices closer than ~1e-6 m are welded (vendor DAEs are split per material)
STL_HEADER = b"svhdesc binary STL".ljust(80, b" ")
_STL_RECORD = np.dtype([("normal", "<f4", (3,)), ("vertices", "<f4", (3, 3)), ("attr", "<u2")])

# COLLADA up axis -> rotation taking its coordinates to Z up (x right, y in, z up)
_UP_AXIS = {
    "Z_UP": None,
    "Y_UP": np.array([[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]]),
    "X_UP": np.array([[0.0, -1.0, 0.0], [0.0, 0.0, -1.0], [1.0, 0.0, 0.0]]),
}


class MeshError(ValueError):
    """A mesh file that is missing, unreadable or empty; the message starts with its path."""


class MeshTooBig(MeshError):
    """A mesh past ``core.limits``' size or triangles: not read further, whoever asks (init says so up front)."""


def _collada_frame(path: Path) -> tuple[float, np.ndarray | None]:
    """(metres per unit, rotation to Z up or None) from a COLLADA ``<asset>``."""
    try:
        root = etree.parse(os.fsencode(path), etree.XMLParser(resolve_entities=False, no_network=True)).getroot()
    except etree.XMLSyntaxError as exc:
        raise MeshError(f"{path}: not a readable COLLADA file ({exc})") from None
    unit = root.find("{*}asset/{*}unit")
    meter = 1.0
    if unit is not None and unit.get("meter") is not None:
        try:
            meter = float(unit.get("meter"))
        except ValueError:
            raise MeshError(f"{path}: bad <unit meter={unit.get('meter')!r}>") from None
        if not np.isfinite(meter) or meter <= 0:
            raise MeshError(f"{path}: bad <unit meter={unit.get('meter')!r}>")
    # Checked on the text: the COLLADA reader turns nan/inf/overflowing numbers into 0.0 or drops them.
    for array in root.iter("{*}float_array"):
        try:
            values = np.array((array.text or "").split(), dtype=np.float64)
        except ValueError:
            raise MeshError(f"{path}: <float_array id={array.get('id')!r}> holds a non-number") from None
        if not np.all(np.isfinite(values)) or np.any(np.abs(values) > MAX_RAW):
            raise MeshError(f"{path}: <float_array id={array.get('id')!r}> holds a non-finite or huge value")
    up = root.findtext("{*}asset/{*}up_axis", default="Z_UP").strip().upper()
    if up not in _UP_AXIS:
        raise MeshError(f"{path}: unknown <up_axis> {up!r}")
    return meter, _UP_AXIS[up]


def _read(path: Path) -> trimesh.Trimesh:
    """Raw triangles of a file, scene-graph transforms baked, in metres and Z up."""
    suffix = path.suffix.lower()
    if suffix not in (".dae", ".stl", ".obj"):
        raise MeshError(f"{path}: unsupported mesh format {path.suffix!r} (use .dae, .stl or .obj)")
    too_big = mesh_size_problem(path)
    if too_big is not None:  # before a parser takes gigabytes over it
        raise MeshTooBig(f"{path}: {too_big}")
    meter, rotation = _collada_frame(path) if suffix == ".dae" else (1.0, None)
    try:
        loaded = trimesh.load(str(path), file_type=suffix[1:], force="mesh", process=False)
    except Exception as exc:  # any parser failure is the file's fault
        raise MeshError(f"{path}: cannot read mesh ({type(exc).__name__}: {exc})") from None
    if isinstance(loaded, trimesh.Scene):  # force="mesh" yields an empty Scene for no geometry
        loaded = loaded.to_mesh() if loaded.geometry else trimesh.Trimesh()
    vertices = np.asarray(getattr(loaded, "vertices", np.zeros((0, 3))), dtype=np.float64)
    faces = np.asarray(getattr(loaded, "faces", np.zeros((0, 3))), dtype=np.int64)
    if len(faces) == 0 or len(vertices) == 0:
        raise MeshError(f"{path}: mesh has no triangles")
    if len(faces) > MAX_MESH_TRIANGLES:  # before welding, winding and decomposing them for minutes
        raise MeshTooBig(
            f"{path}: {len(faces):,} triangles, more than the {MAX_MESH_TRIANGLES:,} MuJoCo reads in a mesh"
        )
    if not np.all(np.isfinite(vertices)):
        raise MeshError(f"{path}: mesh has non-finite vertex coordinates")
    if np.any(faces < 0) or np.any(faces >= len(vertices)):
        raise MeshError(f"{path}: mesh has faces indexing missing vertices")
    vertices = vertices * meter
    if np.max(np.abs(vertices)) > MAX_METRES:
        raise MeshError(f"{path}: mesh has a vertex {np.max(np.abs(vertices)):.3g} m from its origin (huge)")
    if rotation is not None:
        vertices = exact.matmul(vertices, np.asarray(rotation).T)
    return trimesh.Trimesh(vertices=vertices, faces=faces, process=False, validate=False)


def welded(mesh: trimesh.Trimesh) -> trimesh.Trimesh:
    """In place, and returned: vertices within ~1e-6 m merged, degenerate and duplicate faces dropped."""
    mesh.merge_vertices(digits_vertex=MERGE_DIGITS, merge_tex=True, merge_norm=True)
    mesh.update_faces(mesh.nondegenerate_faces())
    mesh.update_faces(mesh.unique_faces())
    mesh.remove_unreferenced_vertices()
    return mesh


def load_mesh(path: Path, scale: tuple[float, float, float] = (1.0, 1.0, 1.0)) -> trimesh.Trimesh:
    """Load a .dae/.stl/.obj as one welded triangle mesh in metres, with ``scale`` baked in.

    Vertices within ~1e-6 m are merged, degenerate and duplicate faces dropped, and the
    winding made consistent (outward when the mesh is closed).  A scale with a negative
    determinant mirrors the mesh; its faces are flipped so that normals stay outward.
    """
    path = Path(path)
    if not path.is_file():
        raise MeshError(f"{path}: no such mesh file")
    s = np.asarray(scale, dtype=np.float64)
    if s.shape != (3,) or not np.all(np.isfinite(s)) or np.any(s == 0):
        raise MeshError(f"{path}: bad scale {tuple(scale)}")
    mesh = welded(_read(path))
    if len(mesh.faces) == 0:
        raise MeshError(f"{path}: mesh has only degenerate triangles")
    spread = np.linalg.svd(np.asarray(mesh.vertices) - np.asarray(mesh.vertices).mean(axis=0), compute_uv=False)
    if len(spread) < 3 or spread[2] <= 1e-9 * spread[0]:
        raise MeshError(f"{path}: mesh is flat (all vertices in one plane): no volume to simulate")
    faces = np.asarray(mesh.faces)
    if np.prod(s) < 0:
        faces = faces[:, ::-1]
    mesh = trimesh.Trimesh(vertices=np.asarray(mesh.vertices) * s, faces=faces, process=False)
    fix_winding(mesh)  # trimesh's result, without its per-pair Python (winding.py)
    if mesh.is_watertight:
        trimesh.repair.fix_inversion(mesh, multibody=True)
    mesh.metadata["file_name"] = path.name
    return mesh


def _name(mesh: trimesh.Trimesh) -> str:
    return str(mesh.metadata.get("file_name", "mesh"))


def _lex_less(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Row-wise lexicographic a < b for (n, 3) arrays."""
    return (a[:, 0] < b[:, 0]) | (
        (a[:, 0] == b[:, 0]) & ((a[:, 1] < b[:, 1]) | ((a[:, 1] == b[:, 1]) & (a[:, 2] < b[:, 2])))
    )


def stl_bytes(mesh: trimesh.Trimesh) -> bytes:
    """Canonical binary STL: fixed header, float32 LE, triangles in a canonical order.

    Each triangle starts at its smallest corner (winding kept) and triangles are sorted by
    their corners, so meshes with the same triangles give the same bytes whatever the
    vertex and face order.  Normals are recomputed from the stored float32 corners.
    """
    tri = np.asarray(mesh.vertices, dtype=np.float64)[np.asarray(mesh.faces, dtype=np.int64)]
    tri32 = tri.astype("<f4") + np.float32(0.0)  # -0.0 -> 0.0
    n = len(tri32)
    if n:
        first = np.zeros(n, dtype=np.int64)  # index of each triangle's lexicographically smallest corner
        rows = np.arange(n)
        for k in (1, 2):
            first[_lex_less(tri32[:, k], tri32[rows, first])] = k
        tri32 = tri32[rows[:, None], (first[:, None] + np.arange(3)[None, :]) % 3]
        tri32 = tri32[np.lexsort(tri32.reshape(n, 9).T[::-1])]
    t = tri32.astype(np.float64)
    cross = np.cross(t[:, 1] - t[:, 0], t[:, 2] - t[:, 0]) if n else np.zeros((0, 3))
    norm = np.linalg.norm(cross, axis=1, keepdims=True)
    normals = np.divide(cross, norm, out=np.zeros_like(cross), where=norm > 0)
    records = np.zeros(n, dtype=_STL_RECORD)
    records["normal"] = normals.astype("<f4") + np.float32(0.0)
    records["vertices"] = tri32
    return STL_HEADER + np.uint32(n).astype("<u4").tobytes() + records.tobytes()


def mesh_from_stl(data: bytes) -> trimesh.Trimesh:
    """Parse a binary STL, merging exactly equal vertices (no tolerance, so nothing collapses)."""
    if len(data) < 84:
        raise ValueError("binary STL shorter than its 84-byte header")
    count = int(np.frombuffer(data, dtype="<u4", count=1, offset=80)[0])
    if len(data) != 84 + count * _STL_RECORD.itemsize:
        raise ValueError(f"binary STL size {len(data)} does not match its {count} triangles")
    records = np.frombuffer(data, dtype=_STL_RECORD, count=count, offset=84)
    corners = records["vertices"].reshape(-1, 3).astype(np.float64)
    vertices, inverse = np.unique(corners, axis=0, return_inverse=True)
    faces = inverse.reshape(-1, 3).astype(np.int64)
    return trimesh.Trimesh(vertices=vertices, faces=faces, process=False, validate=False)


def obj_bytes(mesh: trimesh.Trimesh) -> bytes:
    """Canonical Wavefront OBJ (the collision-mesh format every engine reads, Drake included).

    The same float32 corners as ``stl_bytes``, each written as the shortest decimal of that float32's
    exact double value, so float32 and float64 readers get exactly those corners. Vertices are unique
    and sorted, each face starts at its smallest index (winding kept) and faces are sorted, so the same
    triangles give the same bytes whatever the vertex and face order.
    """
    tri = np.asarray(mesh.vertices, dtype=np.float64)[np.asarray(mesh.faces, dtype=np.int64)]
    tri32 = tri.astype("<f4") + np.float32(0.0)  # -0.0 -> 0.0
    corners = tri32.reshape(-1, 3)
    vertices, inverse = np.unique(corners, axis=0, return_inverse=True)  # lexicographic rows
    faces = inverse.reshape(-1, 3)
    if len(faces):
        first = np.argmin(faces, axis=1)
        faces = faces[np.arange(len(faces))[:, None], (first[:, None] + np.arange(3)[None, :]) % 3]
        faces = faces[np.lexsort(faces.T[::-1])]
    lines = ["# svhdesc OBJ"]
    lines += [f"v {float(x)!r} {float(y)!r} {float(z)!r}" for x, y, z in vertices]
    lines += [f"f {a + 1} {b + 1} {c + 1}" for a, b, c in faces]
    return ("\n".join(lines) + "\n").encode()


def convex_hull(mesh: trimesh.Trimesh) -> trimesh.Trimesh:
    """Convex hull of the vertices (qhull), independent of vertex order, normals outward."""
    points = np.unique(np.asarray(mesh.vertices, dtype=np.float64), axis=0)
    if len(points) < 4:
        raise MeshError(f"{_name(mesh)}: convex hull needs at least 4 distinct vertices")
    spread = np.linalg.svd(points - points.mean(axis=0), compute_uv=False)
    if spread[2] <= 1e-9 * spread[0]:
        raise MeshError(f"{_name(mesh)}: convex hull is degenerate (vertices are coplanar or collinear)")
    try:
        hull = trimesh.convex.convex_hull(points, qhull_options="QbB Pp Qt", repair=True)
    except Exception as exc:  # qhull reports flat input as an error
        raise MeshError(f"{_name(mesh)}: convex hull is degenerate ({type(exc).__name__})") from None
    if hull.volume < 0:
        hull.invert()
    if not (hull.is_watertight and hull.volume > 0 and hull.is_convex):
        raise MeshError(f"{_name(mesh)}: convex hull is degenerate (flat or needle-like)")
    hull.metadata["file_name"] = _name(mesh)
    return hull


def mesh_volume(mesh: trimesh.Trimesh) -> float:
    """Enclosed volume in m^3 of a closed mesh; of its convex hull if the mesh is open."""
    if mesh.is_watertight:
        return abs(exact.mass_properties(mesh.vertices, mesh.faces)[0])
    hull = convex_hull(mesh)
    return exact.mass_properties(hull.vertices, hull.faces)[0]


def principal_cylinder(mesh: trimesh.Trimesh) -> tuple[np.ndarray, np.ndarray, float, float]:
    """Solid cylinder fitted to the convex hull of ``mesh``: (centre, axis, radius, length).

    ``centre`` is the hull's centroid; ``axis`` the unit principal direction of its uniform-density
    inertia with the smallest moment (the long axis), signed so its largest component is positive;
    ``length`` the hull's extent along the axis; ``radius`` the one for which a uniform solid
    cylinder has the hull's moment about that axis, r = sqrt(2 I_axis / V).
    """
    hull = convex_hull(mesh)
    volume, centre, inertia = exact.mass_properties(hull.vertices, hull.faces)
    moments, vectors = exact.eigh3(inertia)
    axis = vectors[:, 0] / exact.norm(vectors[:, 0])
    k = int(np.argmax(np.abs(axis)))
    if axis[k] < 0:
        axis = -axis
    axis = axis + 0.0
    t = exact.matmul(np.asarray(hull.vertices) - centre, axis[:, None])[:, 0]
    length = float(t.max() - t.min())
    radius = float(np.sqrt(max(2.0 * moments[0] / volume, 0.0)))
    return centre, axis, radius, length
