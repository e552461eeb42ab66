"""Which link pairs never collide: neighbours in the tree, and pairs already touching at rest.

The same rule as MoveIt's setup assistant ("adjacent" and "default" pairs): a pair that touches
in the zero configuration is a modelling overlap, not a contact a controller could avoid.
"""

from __future__ import annotations

from dataclasses import replace
from typing import Any

from ..errors import SvhdescError
from ..ir import Robot
from .assets import Assets


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


def touching_at_rest(robot: Robot, assets: Assets, settings: dict[str, Any]) -> set[tuple[str, str]]:
    import mujoco

    from ..export.mjcf import export_mjcf

    xml = export_mjcf(robot, settings).decode()
    try:
        model = mujoco.MjModel.from_xml_string(xml, {f"assets/{k}": v for k, v in assets.files.items()})
    except ValueError as exc:  # MuJoCo's compiler names the element; the IR checks should catch it first
        raise SvhdescError(f"{robot.name}: MuJoCo refuses the model: {str(exc).splitlines()[0]}") from None
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    pairs = set()
    for contact in data.contact[: data.ncon]:
        bodies = [model.body(model.geom_bodyid[g]).name for g in (contact.geom1, contact.geom2)]
        pairs.add((bodies[0], bodies[1]))
    return pairs


def add_excludes(robot: Robot, assets: Assets, settings: dict[str, Any]) -> Robot:
    order = {link.name: i for i, link in enumerate(robot.links)}
    pairs = adjacent_pairs(robot)
    pairs |= touching_at_rest(replace(robot, excludes=tuple(pairs)), assets, settings)
    normalised = {tuple(sorted(pair, key=order.__getitem__)) for pair in pairs}
    return replace(robot, excludes=tuple(sorted(normalised, key=lambda p: (order[p[0]], order[p[1]]))))
