"""Objects placed in a scene, shared by the planner (obstacles) and the simulation (``svhdesc sim --scene``):
boxes and cylinders, fixed in the world, or free bodies when they have a mass.

obstacles:
- {name: table, shape: box, size: [0.5, 0.3, 0.02], position: [0, 0.6, -0.02]}        # half extents
- {name: can, shape: cylinder, size: [0.025, 0.06], position: [0.1, 0.6, 0.06], mass: 0.1}   # radius, half height
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
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
    at: str = field(default="", compare=False)  # file:line of its entry, for errors


def add_objects(spec: Any, objects: Sequence[Obstacle]) -> None:
    """Add ``objects`` to a ``mujoco.MjSpec``: static geoms in the world, or free bodies (named as the object)."""
    import mujoco

    kinds = {"box": mujoco.mjtGeom.mjGEOM_BOX, "cylinder": mujoco.mjtGeom.mjGEOM_CYLINDER}
    taken = {e.name for e in (*spec.bodies, *spec.geoms, *spec.joints) if e.name}
    for item in objects:
        clash = {item.name, f"{item.name}_free"} & taken
        if clash:
            where = item.at or f"object {item.name}"
            raise SvhdescError(
                f"{where}: the name {sorted(clash)[0]!r} is taken by the robot or scene; rename the object"
            )
        taken |= {item.name, f"{item.name}_free"}
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


# Plausibility bounds: a scene is a workcell, not the solar system; beyond them MuJoCo's collision and
# integration stop meaning anything (an object at 1e300 m stalls mj_step for minutes).
MAX_EXTENT = 100.0  # m, any coordinate or size
MAX_MASS = 1e4  # kg
MAX_FRICTION = 10.0
KEYS = {"name", "shape", "size", "position", "mass", "friction"}


def _positive(value: Any, limit: float) -> bool:
    return not isinstance(value, bool) and isinstance(value, (int, float)) and 0 < value <= limit


def _document(path: Path) -> tuple[Any, list[int]]:
    """The scene file's data and the line of each ``obstacles:`` entry (1-based)."""
    import yaml

    try:
        text = path.read_text(encoding="utf-8")
        node, document = yaml.compose(text, Loader=yaml.SafeLoader), yaml.safe_load(text)
    except OSError as exc:
        raise SvhdescError(f"{path}: {exc.strerror}") from None
    except UnicodeDecodeError:
        raise SvhdescError(f"{path}: not a UTF-8 text file") from None
    except yaml.MarkedYAMLError as exc:
        line = f":{exc.problem_mark.line + 1}" if exc.problem_mark else ""
        raise SvhdescError(f"{path}{line}: not YAML ({exc.problem})") from None
    except (yaml.YAMLError, ValueError, RecursionError) as exc:  # ValueError: an integer of 4300+ digits
        raise SvhdescError(f"{path}: not YAML ({type(exc).__name__})") from None
    lines: list[int] = []
    if isinstance(node, yaml.MappingNode):
        for key, value in node.value:
            if key.value == "obstacles" and isinstance(value, yaml.SequenceNode):
                lines = [item.start_mark.line + 1 for item in value.value]
    return document, lines


def load_obstacles(path: Path) -> list[Obstacle]:
    """The ``obstacles:`` list of a scene file (module docstring); errors name the file and the entry's line."""
    document, lines = _document(path)
    entries = document.get("obstacles") if isinstance(document, dict) else None
    if not isinstance(entries, list):
        raise SvhdescError(f"{path}: expected an 'obstacles:' list")
    found: list[Obstacle] = []
    for i, entry in enumerate(entries):
        at = f"{path}:{lines[i]}" if i < len(lines) else f"{path}: obstacles[{i}]"
        item = _obstacle(entry, i, at)
        if any(other.name == item.name for other in found):
            raise SvhdescError(f"{at}: a second object named {item.name!r}")
        found.append(item)
    return found


def _obstacle(entry: Any, i: int, at: str) -> Obstacle:
    try:
        shape, size, position = (
            entry["shape"],
            [float(v) for v in entry["size"]],
            [float(v) for v in entry["position"]],
        )
        name = str(entry.get("name", f"obstacle_{i}"))
    except (TypeError, KeyError, ValueError, OverflowError) as exc:
        raise SvhdescError(f"{at}: needs shape, size and position ({exc})") from None
    unknown = sorted(set(entry) - KEYS)
    if unknown:
        raise SvhdescError(f"{at}: unknown keys {unknown}")
    want = SHAPES.get(shape)
    if want is None or len(size) != want or len(position) != 3:
        raise SvhdescError(f"{at}: a box has 3 half sizes, a cylinder 2 (radius, half height); position x y z")
    if not all(math.isfinite(v) for v in size + position) or min(size) <= 0:
        raise SvhdescError(f"{at}: sizes must be positive and every number finite")
    if max(abs(v) for v in size + position) > MAX_EXTENT:
        raise SvhdescError(f"{at}: sizes and positions must be within {MAX_EXTENT:g} m")
    mass = entry.get("mass")
    if mass is not None and not _positive(mass, MAX_MASS):
        raise SvhdescError(f"{at}: mass must be a number in (0, {MAX_MASS:g}] kg, got {mass!r}")
    friction = entry.get("friction", 1.0)
    if not _positive(friction, MAX_FRICTION):
        raise SvhdescError(f"{at}: friction must be a number in (0, {MAX_FRICTION:g}], got {friction!r}")
    return Obstacle(name, shape, tuple(size), tuple(position), mass, float(friction), at)
