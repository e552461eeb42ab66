"""Source meshes -> baked STL assets: visual meshes as they are; collisions as the link's rule says
(one convex hull, a CoACD decomposition into several hulls, or a fitted primitive)."""

from __future__ import annotations

from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np
import trimesh

from svhdesc.compiler.assets import Assets
from svhdesc.compiler.decompose import DecompParams, bounded_hull
from svhdesc.compiler.decompose.source import HullSource
from svhdesc.compiler.stages.collision_rules import CollisionRule
from svhdesc.core import exact
from svhdesc.core.frames import axis_frame, matrix_pose, pose_matrix
from svhdesc.core.source.meshes import MeshError, convex_hull, load_mesh, obj_bytes, principal_cylinder, stl_bytes
from svhdesc.errors import SvhdescError
from svhdesc.ir import Geometry, Robot

Scale = tuple[float, float, float]


def _tag(scale: Scale) -> str:
    """Asset-name suffix for a baked scale: mirrored axes by name (-1 1 1 -> '_mirror_x')."""
    if all(abs(s) == 1.0 for s in scale):
        axes = "".join(axis for axis, s in zip("xyz", scale) if s < 0)
        return f"_mirror_{axes}" if axes else ""
    return "_scale_" + "_".join(f"{s:g}".replace("-", "m").replace(".", "p") for s in scale)


_LOADED: dict[tuple[str, int, int, Scale], trimesh.Trimesh] = {}


def _load(source: Path, scale: Scale = (1.0, 1.0, 1.0)) -> trimesh.Trimesh:
    """``load_mesh``, once per file version and scale in a process (variants share their meshes)."""
    try:
        stat = source.stat()
        key = (str(source), stat.st_mtime_ns, stat.st_size, scale)
        if key not in _LOADED:
            _LOADED[key] = load_mesh(source, scale)
        return _LOADED[key].copy()
    except (MeshError, OSError) as exc:
        raise SvhdescError(str(exc) if isinstance(exc, MeshError) else f"{source}: {exc.strerror}") from None


def scaled(mesh: trimesh.Trimesh, scale: Scale) -> trimesh.Trimesh:
    """A hull under a (possibly mirroring) scale; the hull of a mirror image is the mirror of the hull."""
    if scale == (1.0, 1.0, 1.0):
        return mesh
    result = mesh.copy()
    result.apply_transform(np.diag([*scale, 1.0]))
    if np.prod(scale) < 0:
        result.invert()
    return convex_hull(result)


_HULLS: dict[tuple[str, int, int, Scale, int], trimesh.Trimesh] = {}


def _hull(source: Path, scale: Scale, max_vertices: int) -> trimesh.Trimesh:
    """One convex hull, its corners bounded like a decomposition's (simulators pay per vertex)."""
    stat = source.stat()
    key = (str(source), stat.st_mtime_ns, stat.st_size, scale, max_vertices)
    if key not in _HULLS:
        _HULLS[key] = bounded_hull(_load(source, scale), max_vertices)
    return _HULLS[key].copy()


def fit_primitive(mesh: trimesh.Trimesh, shape: str, origin: Geometry) -> Geometry:
    """A capsule/cylinder along the principal axis, or the oriented bounding box, in the link frame."""
    if shape == "box":
        box = mesh.bounding_box_oriented
        frame, size = np.asarray(box.primitive.transform), tuple(float(v) for v in box.primitive.extents)
    else:
        centre, axis, radius, length = principal_cylinder(mesh)
        frame = np.eye(4)
        frame[:3, :3] = axis_frame(axis)
        frame[:3, 3] = centre
        size = (radius, max(length - 2.0 * radius, 1e-4)) if shape == "capsule" else (radius, length)
    pose = matrix_pose(exact.matmul(pose_matrix(origin.origin), frame))
    return Geometry(shape, pose, size)


@dataclass(frozen=True)
class Meshes:
    """What baking reads: each link's collision rule (from the plan) and where decompositions come from."""

    rules: dict[str, CollisionRule]
    hulls: HullSource | None = None


def bake_meshes(robot: Robot, assets: Assets, section: Meshes) -> Robot:
    """Replace every mesh reference by assets; scales are baked into the vertices."""
    rules, hulls = section.rules, section.hulls
    stems: dict[str, str] = {}  # asset stem -> source file, to catch two sources with one name
    done: dict[tuple, list[Geometry]] = {}

    def stem_of(source: Path) -> str:
        stem = source.stem
        owner = Path(stems.setdefault(stem, str(source)))
        if owner != source:  # a.stl beside a.dae, or a.dae in two directories: both must survive
            stem = (
                f"{stem}_{source.suffix.lstrip('.')}"
                if owner.parent == source.parent
                else f"{source.parent.name}_{stem}"
            )
            stems.setdefault(stem, str(source))
        return stem

    def bake(geometry: Geometry, role: str, rule: CollisionRule) -> list[Geometry]:
        if geometry.kind != "mesh":
            return [geometry]
        key = (geometry.mesh, geometry.scale, role, rule)
        if key not in done:
            source = Path(geometry.mesh or "")
            name = stem_of(source) + _tag(geometry.scale)
            plain = replace(geometry, scale=(1.0, 1.0, 1.0))
            if role == "visual":
                mesh = _load(source, geometry.scale)
                done[key] = [replace(plain, mesh=assets.add(f"{name}.stl", mesh, stl_bytes(mesh)))]
            elif rule.mode == "primitive":
                fitted = fit_primitive(_load(source, geometry.scale), rule.primitive, geometry)
                done[key] = [replace(fitted, rgba=None)]
            elif rule.mode == "decompose" and hulls is not None and rule.params is not None:
                # Decompose the unscaled source once; each mirror image reuses it.
                decomposition, parts = hulls.get(_load(source), rule.params)
                names = []
                for i, part in enumerate(parts):
                    part = scaled(part, geometry.scale)
                    names.append(assets.add(f"{name}_hull_{i:02d}.obj", part, obj_bytes(part)))
                if geometry.scale == (1.0, 1.0, 1.0):
                    assets.decompositions[decomposition] = names
                done[key] = [replace(plain, mesh=n) for n in names]
            else:
                limit = rule.params.max_hull_vertices if rule.params else DecompParams().max_hull_vertices
                mesh = _hull(source, geometry.scale, limit)
                done[key] = [replace(plain, mesh=assets.add(f"{name}_hull.obj", mesh, obj_bytes(mesh)))]
        return done[key]

    links = []
    for link in robot.links:
        rule = rules.get(link.name, CollisionRule())
        visuals = tuple(g for v in link.visuals for g in bake(v, "visual", rule))
        collisions = tuple(g for c in link.collisions for g in bake(c, "collision", rule))
        links.append(replace(link, visuals=visuals, collisions=collisions))
    return replace(robot, links=tuple(links))


def decomposition_jobs(robot: Robot, rules: dict[str, CollisionRule]) -> list[tuple[str, trimesh.Trimesh, object]]:
    """(name, unscaled source mesh, params) for every decomposed collision mesh, for prefetching."""
    jobs = {}
    for link in robot.links:
        rule = rules.get(link.name)
        if rule is None or rule.mode != "decompose":
            continue
        for geometry in link.collisions:
            if geometry.kind == "mesh" and (geometry.mesh, rule.params) not in jobs:
                jobs[(geometry.mesh, rule.params)] = (link.name, _load(Path(geometry.mesh or "")), rule.params)
    return list(jobs.values())
