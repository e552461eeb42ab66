"""Which collision model each link gets: one convex hull, a CoACD decomposition, or a primitive."""

from __future__ import annotations

import fnmatch
from dataclasses import dataclass
from typing import Any

from svhdesc.compiler.decompose import LINK_CLASS_PARAMS, DecompParams
from svhdesc.core.settings.yamlio import where
from svhdesc.errors import SvhdescError
from svhdesc.ir import Robot

MODES = ("hull", "decompose", "primitive")
PRIMITIVES = ("capsule", "cylinder", "box")
RULE_KEYS = {"mode", "primitive", "params"}


@dataclass(frozen=True)
class CollisionRule:
    mode: str = "hull"
    primitive: str = "capsule"
    params: DecompParams | None = None
    link_class: str = ""


def _rule(entry: dict[str, Any], base: CollisionRule, global_params: dict[str, Any], where: str) -> CollisionRule:
    unknown = set(entry) - RULE_KEYS - {"name", "links"}
    if unknown:
        raise SvhdescError(f"{where}: unknown key(s) {sorted(unknown)}")
    mode = entry.get("mode", base.mode)
    primitive = entry.get("primitive", base.primitive)
    if mode not in MODES:
        raise SvhdescError(f"{where}: collision mode {mode!r} is not one of {MODES}")
    if primitive not in PRIMITIVES:
        raise SvhdescError(f"{where}: primitive {primitive!r} is not one of {PRIMITIVES}")
    link_class = entry.get("name", base.link_class)
    # Preset of the class, then the global parameters, then this entry's own.
    params = LINK_CLASS_PARAMS.get(link_class, base.params or DecompParams())
    try:
        params = DecompParams.from_mapping(global_params, params)
        params = DecompParams.from_mapping(entry.get("params") or {}, params)
    except ValueError as exc:
        raise SvhdescError(f"{where}: {exc}") from None
    return CollisionRule(mode, primitive, params, link_class)


def _classes(
    collision: dict[str, Any], at: str, default: CollisionRule, global_params: dict[str, Any], hand_prefix: str | None
) -> list[tuple[list[str], CollisionRule]]:
    """(link patterns, rule) of each entry of ``collision.classes``, in order."""
    classes = []
    entries = collision.get("classes") or []
    if not isinstance(entries, list):
        raise SvhdescError(f"{where(collision, at, 'classes')}: collision.classes must be a list")
    for index, entry in enumerate(entries):
        label = f"{where(entry, where(collision, at, 'classes'))}: collision.classes[{index}]"
        if not isinstance(entry, dict) or not isinstance(entry.get("links", []), list):
            raise SvhdescError(f"{label}: must be a mapping with a list of 'links'")
        patterns = [str(p).format(hand=hand_prefix or "") for p in entry.get("links", [])]
        classes.append((patterns, _rule(entry, default, global_params, label)))
    return classes


def collision_rules(robot: Robot, collision: dict[str, Any], hand_prefix: str | None) -> dict[str, CollisionRule]:
    """Rule per link with collision geometry: first matching class, then per-link overrides."""
    at = where(collision, "collision")
    unknown = set(collision) - {"mode", "primitive", "params", "classes", "links", "exclude"}
    if unknown:
        raise SvhdescError(f"{at}: collision: unknown key(s) {sorted(map(str, unknown))}")
    global_params = collision.get("params") or {}
    if not isinstance(global_params, dict):
        raise SvhdescError(f"{where(collision, at, 'params')}: collision.params must be a mapping")
    default = _rule(
        {k: v for k, v in collision.items() if k in {"mode", "primitive"}},
        CollisionRule(),
        {},
        f"{where(collision, at, 'mode')}: collision",
    )
    classes = _classes(collision, at, default, global_params, hand_prefix)
    overrides = collision.get("links") or {}
    if not isinstance(overrides, dict) or not all(isinstance(v, dict) for v in overrides.values()):
        raise SvhdescError(f"{where(collision, at, 'links')}: collision.links must map links to rules")
    names = {link.name for link in robot.links}
    for name in overrides:
        if str(name).format(hand=hand_prefix or "") not in names and "{hand}" not in str(name):
            raise SvhdescError(f"{where(overrides, at, name)}: collision.links: unknown link {name!r}")
    rules = {}
    for link in robot.links:
        if not link.collisions:
            continue
        rule = next(
            (r for patterns, r in classes if any(fnmatch.fnmatchcase(link.name, p) for p in patterns)),
            _rule({}, default, global_params, f"{at}: collision"),
        )
        for name, entry in overrides.items():
            if str(name).format(hand=hand_prefix or "") == link.name:
                rule = _rule(entry, rule, {}, f"{where(overrides, at, name)}: collision.links.{name}")
        rules[link.name] = rule
    return rules
