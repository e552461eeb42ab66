"""Source meshes -> baked STL assets: visual meshes as they are, collisions as convex hulls."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

from ..errors import SvhdescError
from ..ir import Geometry, Robot
from ..meshes import MeshError, convex_hull, load_mesh, stl_bytes
from .assets import Assets


def _tag(scale: tuple[float, float, float]) -> str:
    """Asset-name suffix for a baked scale: mirrored axes by name (-1 1 1 -> '_mirror_x')."""
    if all(abs(s) == 1.0 for s in scale):
        axes = "".join(axis for axis, s in zip("xyz", scale) if s < 0)
        return f"_mirror_{axes}" if axes else ""
    return "_scale_" + "_".join(f"{s:g}".replace("-", "m").replace(".", "p") for s in scale)


def bake_meshes(robot: Robot, assets: Assets) -> Robot:
    """Replace every mesh reference by an asset name; scales are baked into the vertices."""
    stems: dict[str, str] = {}  # asset stem -> source path, to catch two sources with one name
    loaded: dict[tuple[str, tuple[float, float, float], str], str] = {}

    def asset(geometry: Geometry, role: str) -> Geometry:
        if geometry.kind != "mesh":
            return geometry
        key = (geometry.mesh or "", geometry.scale, role)
        if key not in loaded:
            source = Path(geometry.mesh or "")
            stem = source.stem
            if stems.setdefault(stem, str(source.parent)) != str(source.parent):
                stem = f"{source.parent.name}_{stem}"
            name = f"{stem}{_tag(geometry.scale)}"
            try:
                mesh = load_mesh(source, geometry.scale)
            except MeshError as exc:
                raise SvhdescError(str(exc)) from None
            if role == "collision":
                mesh = convex_hull(mesh)
                name += "_hull"
            loaded[key] = assets.add(f"{name}.stl", mesh, stl_bytes(mesh))
        return replace(geometry, mesh=loaded[key], scale=(1.0, 1.0, 1.0))

    links = []
    for link in robot.links:
        visuals = tuple(asset(g, "visual") for g in link.visuals)
        collisions = tuple(asset(g, "collision") for g in link.collisions)
        links.append(replace(link, visuals=visuals, collisions=collisions))
    return replace(robot, links=tuple(links))
