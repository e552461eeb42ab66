"""Which link pairs never collide: neighbours in the tree, and pairs already touching at rest.

The same rule as MoveIt's setup assistant ("adjacent" and "default" pairs): a pair that touches
in the zero configuration is a modelling overlap, not a contact a controller could avoid.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import replace

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


def add_excludes(robot: Robot, touching: Callable[[Robot], set[tuple[str, str]]]) -> Robot:
    """Adjacent pairs, then the pairs ``touching`` finds in contact at rest with those excluded (the
    pipeline supplies the probe: a stage does not reach into an exporter)."""
    order = {link.name: i for i, link in enumerate(robot.links)}
    pairs = adjacent_pairs(robot)
    pairs |= touching(replace(robot, excludes=tuple(pairs)))
    normalised = {tuple(sorted(pair, key=order.__getitem__)) for pair in pairs}
    return replace(robot, excludes=tuple(sorted(normalised, key=lambda p: (order[p[0]], order[p[1]]))))
