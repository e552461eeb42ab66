"""A robot's faults worked around by settings, not edits: ``joints.NAME`` keys that patch the source's ``<joint>``
before it is read, so every later step (the coupling spec from ``<mimic>`` tags, the drives, every output) sees the
joint as the settings say.

- ``mimic: drop``: the joint's ``<mimic>`` tag is ignored (a mimic naming a joint that does not exist, as the Alex
  with PSYONIC hands writes its fingers' without their side prefix); ``mimic: LEADER``: it follows LEADER instead,
  with the tag's multiplier and offset;
- ``effort``, ``velocity``: the drive's rating where the source gives none (``<limit effort="0">``);
- ``lower``, ``upper``: the limits where the source's are unusable (inverted, as pybullet's "no limit" convention
  writes them, or absent);
- ``type: continuous``: a revolute joint that turns without end (a wheel, a rotor) written with no usable limits
  (centauro's wheels, the iris' rotors at +-1e16); ``type: fixed``: the joint locked at 0;
- ``rename: NEW``: the joint's name where the source's cannot stand: a joint named like a link (the SO-100's
  ``gripper``), which SDFormat refuses, as its frames share one namespace. ``<mimic>`` tags naming it follow.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from lxml import etree

from svhdesc.errors import SvhdescError

DROP = "drop"
LIMIT_KEYS = ("effort", "velocity", "lower", "upper")
TYPES = ("continuous", "fixed")  # what joints.NAME.type may make a joint


def _value(quirk: Any, key: str) -> Any:
    return quirk.get(key) if isinstance(quirk, Mapping) else getattr(quirk, key, None)


def apply_joint_quirks(tree: etree._Element, quirks: Mapping[str, Any], where: Mapping[str, str]) -> etree._Element:
    """``tree`` (a URDF ``<robot>``) with each ``joints.NAME`` quirk applied, in place; ``where``: each name's
    file:line in the config, for the one error a quirk on no joint of the source gives."""
    joints = {element.get("name"): element for element in tree.findall("joint")}
    for name, quirk in quirks.items():
        patch = {key: _value(quirk, key) for key in (*LIMIT_KEYS, "mimic", "rename", "type")}
        if all(value is None for value in patch.values()):
            continue  # damping and friction only: the actuation stage applies those
        element = joints.get(name)
        if element is None:
            raise SvhdescError(f"{where.get(name, 'config')}: joints.{name}: no joint {name!r} in the source")
        limits = {key: patch[key] for key in LIMIT_KEYS if patch[key] is not None}
        if limits:
            limit = element.find("limit")
            if limit is None:
                limit = etree.SubElement(element, "limit")
            for key, value in limits.items():
                limit.set(key, repr(float(value)))
        _patch_mimic(element, patch["mimic"], name, where)
        _patch_type(element, patch["type"], name, where)
    for name, quirk in quirks.items():  # last: the other keys name the source's joints
        new = _value(quirk, "rename")
        if new is not None:
            _rename(tree, joints[name], str(new), where.get(name, "config"))
    return tree


def _rename(tree: etree._Element, element: etree._Element, new: str, where: str) -> None:
    taken = {e.get("name") for e in tree.findall("joint")} | {e.get("name") for e in tree.findall("link")}
    if new in taken:
        raise SvhdescError(f"{where}: joints.{element.get('name')}.rename: {new!r} is taken by a link or joint")
    old = element.get("name")
    element.set("name", new)
    for mimic in tree.iter("mimic"):
        if mimic.get("joint") == old:
            mimic.set("joint", new)


def clashing_names(tree: etree._Element) -> dict[str, str]:
    """{joint: a free new name} for every joint named like a link, which SDFormat refuses: ``NAME_joint``."""
    links = {e.get("name") for e in tree.findall("link")}
    taken = links | {e.get("name") for e in tree.findall("joint")}
    renames = {}
    for element in tree.findall("joint"):
        name = element.get("name")
        if name in links:
            new, n = f"{name}_joint", 2
            while new in taken:
                new, n = f"{name}_joint{n}", n + 1
            taken.add(new)
            renames[str(name)] = new
    return renames


def _patch_type(element: etree._Element, kind: str | None, name: str, where: Mapping[str, str]) -> None:
    if kind is None:
        return
    if kind == "continuous" and element.get("type") not in ("revolute", "continuous"):
        raise SvhdescError(
            f"{where.get(name, 'config')}: joints.{name}.type: continuous: joint {name} is {element.get('type')}, "
            "not revolute"
        )
    element.set("type", kind)


def _patch_mimic(element: etree._Element, mimic: str | None, name: str, where: Mapping[str, str]) -> None:
    if mimic is None:
        return
    tag = element.find("mimic")
    if tag is None:
        raise SvhdescError(f"{where.get(name, 'config')}: joints.{name}.mimic: joint {name} has no <mimic> tag")
    if mimic == DROP:
        element.remove(tag)
    else:
        tag.set("joint", mimic)
