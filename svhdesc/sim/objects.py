"""Objects placed in a scene, shared by the planner (obstacles) and the simulation (``svhdesc sim --scene``):
boxes and cylinders, fixed in the world, or free bodies when they have a mass.

obstacles:
- {name: table, shape: box, size: [0.5, 0.3, 0.02], position: [0, 0.6, -0.02]}        # half extents
- {name: can, shape: cylinder, size: [0.025, 0.06], position: [0.1, 0.6, 0.06], mass: 0.1}   # radius, half height
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from svhdesc.errors import SvhdescError

SHAPES = {"box": 3, "cylinder": 2}


@dataclass(frozen=True)
class Obstacle:
    """A box (size = half extents x y z) or cylinder (size = radius, half height); fixed, or free with ``mass``."""

    name: str
    shape: str  # "box" | "cylinder"
    size: tuple[float, ...]
    position: tuple[float, float, float]
    mass: float | None = None
    friction: float = 1.0


def add_objects(spec: Any, objects: Sequence[Obstacle]) -> None:
    """Add ``objects`` to a ``mujoco.MjSpec``: static geoms in the world, or free bodies (named as the object)."""
    import mujoco

    kinds = {"box": mujoco.mjtGeom.mjGEOM_BOX, "cylinder": mujoco.mjtGeom.mjGEOM_CYLINDER}
    for item in objects:
        if item.shape not in kinds:
            raise SvhdescError(f"object {item.name}: shape must be box or cylinder, not {item.shape}")
        size = [*item.size, 0.0, 0.0][:3]
        geom = {"type": kinds[item.shape], "size": size, "friction": [item.friction, 0.005, 0.0001]}
        if item.mass is None:
            spec.worldbody.add_geom(name=item.name, pos=list(item.position), **geom)
        else:
            body = spec.worldbody.add_body(name=item.name, pos=list(item.position))
            body.add_freejoint(name=f"{item.name}_free")
            body.add_geom(name=item.name, mass=item.mass, condim=4, rgba=[0.8, 0.3, 0.2, 1], **geom)


def load_obstacles(path: Path) -> list[Obstacle]:
    """The ``obstacles:`` list of a scene file (module docstring); errors name the entry."""
    import yaml

    try:
        document = yaml.safe_load(path.read_text())
    except OSError as exc:
        raise SvhdescError(f"{path}: {exc.strerror}") from None
    except yaml.YAMLError as exc:
        raise SvhdescError(f"{path}: not YAML: {exc}") from None
    entries = document.get("obstacles") if isinstance(document, dict) else None
    if not isinstance(entries, list):
        raise SvhdescError(f"{path}: expected an 'obstacles:' list")
    found = []
    for i, entry in enumerate(entries):
        where = f"{path}: obstacles[{i}]"
        try:
            shape, size, position = (
                entry["shape"],
                [float(v) for v in entry["size"]],
                [float(v) for v in entry["position"]],
            )
            name = str(entry.get("name", f"obstacle_{i}"))
        except (TypeError, KeyError, ValueError) as exc:
            raise SvhdescError(f"{where}: needs shape, size and position ({exc})") from None
        want = SHAPES.get(shape)
        if want is None or len(size) != want or len(position) != 3:
            raise SvhdescError(f"{where}: a box has 3 half sizes, a cylinder 2 (radius, half height); position x y z")
        if not all(math.isfinite(v) for v in size + position) or min(size) <= 0:
            raise SvhdescError(f"{where}: sizes must be positive and every number finite")
        mass = entry.get("mass")
        if mass is not None and (isinstance(mass, bool) or not isinstance(mass, (int, float)) or not mass > 0):
            raise SvhdescError(f"{where}: mass must be a positive number, got {mass!r}")
        friction = entry.get("friction", 1.0)
        if isinstance(friction, bool) or not isinstance(friction, (int, float)) or not friction > 0:
            raise SvhdescError(f"{where}: friction must be a positive number, got {friction!r}")
        unknown = sorted(set(entry) - {"name", "shape", "size", "position", "mass", "friction"})
        if unknown:
            raise SvhdescError(f"{where}: unknown keys {unknown}")
        found.append(Obstacle(name, shape, tuple(size), tuple(position), mass, float(friction)))
    return found
