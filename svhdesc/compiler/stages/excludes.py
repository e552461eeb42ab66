"""Which link pairs never collide: neighbours in the tree, and pairs already touching at rest.

The same rule as MoveIt's setup assistant ("adjacent" and "default" pairs): a pair that touches
in the zero configuration is a modelling overlap, not a contact a controller could avoid.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import replace
from typing import Any

from svhdesc.core.settings.yamlio import where
from svhdesc.errors import SvhdescError
from svhdesc.ir import Robot


def adjacent_pairs(robot: Robot) -> set[tuple[str, str]]:
    """Collision links at most two steps apart (parent, grandparent, sibling), looking through
    geometry-less links: a proximal phalanx rests against the palm across its knuckle link."""
    parent_of = {j.child: j.parent for j in robot.joints}
    colliding = [link.name for link in robot.links if link.collisions]

    def collision_parent(name: str) -> str | None:
        ancestor = parent_of.get(name)
        while ancestor is not None and ancestor not in colliding:
            ancestor = parent_of.get(ancestor)
        return ancestor

    up = {name: collision_parent(name) for name in colliding}
    pairs = set()
    for name in colliding:
        parent = up[name]
        if parent is None:
            continue
        pairs.add((parent, name))
        if up[parent] is not None:
            pairs.add((up[parent], name))
        pairs.update((sibling, name) for sibling in colliding if sibling < name and up[sibling] == parent)
    return pairs


def configured_excludes(robot: Robot, collision: dict[str, Any]) -> set[tuple[str, str]]:
    """``collision.exclude``: extra link pairs that never collide ([[LINK, LINK], ...]), each link checked."""
    value = collision.get("exclude") or []
    at = where(collision, "collision", "exclude")
    names = {link.name for link in robot.links}
    if not isinstance(value, list):
        raise SvhdescError(f"{at}: collision.exclude must be a list of [LINK, LINK] pairs, got {value!r}")
    pairs = set()
    for pair in value:
        if not (isinstance(pair, list) and len(pair) == 2 and all(isinstance(n, str) for n in pair)):
            raise SvhdescError(f"{at}: collision.exclude: {pair!r} is no [LINK, LINK] pair")
        unknown = [n for n in pair if n not in names]
        if unknown:
            raise SvhdescError(f"{at}: collision.exclude: no link {unknown[0]!r} in robot {robot.name}")
        pairs.add((pair[0], pair[1]))
    return pairs


def add_excludes(
    robot: Robot, touching: Callable[[Robot], set[tuple[str, str]]], extra: set[tuple[str, str]] = frozenset()
) -> Robot:
    """Adjacent pairs and ``extra`` (configured), then the pairs ``touching`` finds in contact at rest with
    those excluded (the pipeline supplies the probe: a stage does not reach into an exporter)."""
    order = {link.name: i for i, link in enumerate(robot.links)}
    pairs = adjacent_pairs(robot) | set(extra)
    pairs |= touching(replace(robot, excludes=tuple(pairs)))
    normalised = {tuple(sorted(pair, key=order.__getitem__)) for pair in pairs}
    return replace(robot, excludes=tuple(sorted(normalised, key=lambda p: (order[p[0]], order[p[1]]))))
