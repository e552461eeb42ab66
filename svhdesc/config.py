"""The build configuration: variants and the physics settings injected into them."""

from __future__ import annotations

import copy
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from .errors import SvhdescError
from .yamlio import load_yaml, where

# Every section a config may hold, with the keys it accepts (None: free-form mapping).
SECTIONS: dict[str, set[str] | None] = {
    "packages": None,
    "coupling": None,
    "coupled_limits": None,
    "hand": {
        "prefix",
        "fingertips",
        "force_sensor",
        "joint_damping",
        "joint_armature",
        "kp",
        "dampratio",
        "limit_margin",
        "limit_solref",
    },
    "arm": {"enabled", "joints", "kp", "dampratio", "joint_damping", "joint_armature"},
    "mass": {"budgets", "links", "inertials"},
    "contact": {"model", "sliding", "torsional", "rolling", "default_sliding"},
    "transmissions": {"interface"},
    "simulation": {"timestep", "coupling_solref", "coupling_solimp", "noslip_iterations", "gravity_compensation"},
    "keyframes": None,
    "collision": None,
    "scene": {"floor_z", "pedestal_radius"},
}
VARIANT_KEYS = {"xacro", "args"} | set(SECTIONS)
CONTACT_MODELS = {"point": 1, "hard_finger": 3, "soft_finger": 4}


@dataclass(frozen=True)
class Variant:
    name: str
    xacro: Path
    args: dict[str, str]
    settings: dict[str, Any]  # merged defaults + overrides
    config_dir: Path

    @property
    def hand(self) -> dict[str, Any]:
        return self.settings["hand"]

    @property
    def arm(self) -> dict[str, Any]:
        return self.settings["arm"]

    def path(self, key: str) -> Path:
        return (self.config_dir / self.settings[key]).resolve()

    def packages(self) -> dict[str, Path]:
        return {name: (self.config_dir / d).resolve() for name, d in (self.settings["packages"] or {}).items()}


@dataclass(frozen=True)
class Config:
    path: Path
    variants: dict[str, Variant]
    files: tuple[Path, ...] = ()  # this file and every file it extends: inputs of every variant

    def select(self, names: list[str] | tuple[str, ...]) -> list[Variant]:
        for name in names:
            if name not in self.variants:
                known = ", ".join(self.variants)
                raise SvhdescError(f"unknown variant '{name}' (known: {known}; see {self.path})")
        return [self.variants[n] for n in (names or self.variants)]


def _merge(base: dict[str, Any], override: dict[str, Any]) -> dict[str, Any]:
    merged = copy.deepcopy(base)
    for key, value in override.items():
        if isinstance(value, dict) and isinstance(merged.get(key), dict) and key not in {"keyframes", "args"}:
            merged[key] = _merge(merged[key], value)
        else:
            merged[key] = copy.deepcopy(value)
    return merged


def _check_sections(data: dict[str, Any], at: str) -> None:
    for section, keys in SECTIONS.items():
        value = data.get(section)
        if keys is None or value is None:
            continue
        if not isinstance(value, dict):
            raise SvhdescError(f"{where(value, at)}: '{section}' must be a mapping")
        unknown = set(value) - keys
        if unknown:
            raise SvhdescError(f"{where(value, at)}: unknown key(s) {sorted(unknown)} in '{section}'")


def _read(path: Path, chain: tuple[Path, ...] = (), files: list[Path] | None = None) -> dict[str, Any]:
    """The config's mapping with ``extends: BASE`` resolved (the base's variants are not inherited)."""
    data = load_yaml(path)
    if files is not None:
        files.append(path.resolve())
    if not isinstance(data, dict):
        raise SvhdescError(f"{path}: config must be a mapping")
    base_name = data.pop("extends", None)
    if base_name is None:
        return data
    base_path = (path.parent / str(base_name)).resolve()
    if base_path in chain:
        raise SvhdescError(f"{where(data, str(path))}: 'extends' loops back to {base_path}")
    base = _read(base_path, (*chain, path.resolve()), files)
    base.pop("variants", None)
    # Paths in the base stay relative to the base file.
    for key in ("coupling",):
        if key in base:
            base[key] = str((base_path.parent / base[key]).resolve())
    if "packages" in base:
        base["packages"] = {k: str((base_path.parent / v).resolve()) for k, v in base["packages"].items()}
    merged = _merge(base, data)
    if isinstance(data, dict) and hasattr(data, "where"):
        merged = type(data)(merged)
        merged.where = data.where  # type: ignore[attr-defined]
    return merged


def load_config(path: Path) -> Config:
    path = Path(path)
    files: list[Path] = []
    data = _read(path, files=files)
    if not isinstance(data.get("variants"), dict) or not data["variants"]:
        raise SvhdescError(f"{path}: config needs a non-empty 'variants' mapping")
    unknown = set(data) - set(SECTIONS) - {"variants"}
    if unknown:
        raise SvhdescError(f"{where(data, str(path))}: unknown top-level key(s) {sorted(unknown)}")
    defaults = {key: value for key, value in data.items() if key != "variants"}
    defaults.setdefault("coupled_limits", "error")
    for section in (
        "hand",
        "arm",
        "mass",
        "contact",
        "transmissions",
        "simulation",
        "keyframes",
        "collision",
        "scene",
    ):
        defaults.setdefault(section, {})
    _check_sections(defaults, str(path))
    variants = {}
    for name, entry in data["variants"].items():
        at = where(entry, str(path))
        if not isinstance(entry, dict) or "xacro" not in entry:
            raise SvhdescError(f"{at}: variant {name} needs an 'xacro' entry point")
        bad = set(entry) - VARIANT_KEYS
        if bad:
            raise SvhdescError(f"{at}: variant {name}: unknown key(s) {sorted(bad)}")
        settings = _merge(defaults, {k: v for k, v in entry.items() if k not in {"xacro", "args"}})
        _check_sections(settings, at)
        if "coupling" not in settings:
            raise SvhdescError(f"{at}: variant {name} has no 'coupling' spec")
        if settings["coupled_limits"] not in {"error", "widen"}:
            raise SvhdescError(f"{at}: coupled_limits must be 'error' or 'widen'")
        model = settings["contact"].get("model", "soft_finger")
        if model not in CONTACT_MODELS:
            raise SvhdescError(f"{at}: contact model '{model}' is not one of {sorted(CONTACT_MODELS)}")
        xacro_path = (path.parent / entry["xacro"]).resolve()
        args = {str(k): str(v) for k, v in (entry.get("args") or {}).items()}
        variants[name] = Variant(name, xacro_path, args, settings, path.parent.resolve())
    return Config(path, variants, tuple(files))
