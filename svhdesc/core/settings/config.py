"""The build configuration: variants and the physics settings injected into them."""

from __future__ import annotations

import copy
import importlib.util
import re
import site
import sysconfig
from dataclasses import dataclass, fields
from pathlib import Path
from typing import Any

from svhdesc.core.settings.schema import CONTACT_MODELS, Settings, mapping_of, normalise, text
from svhdesc.core.settings.yamlio import Node, load_yaml, where
from svhdesc.errors import SvhdescError

# Every section a config may hold: the fields of the one schema (svhdesc.core.settings.schema).
SECTIONS: tuple[str, ...] = tuple(f.name for f in fields(Settings) if not f.metadata.get("located"))
VARIANT_KEYS = {"xacro", "args"} | set(SECTIONS)
__all__ = ["CONTACT_MODELS", "Config", "Variant", "load_config"]


@dataclass(frozen=True)
class Variant:
    name: str
    xacro: Path
    args: dict[str, str]
    settings: Settings  # merged defaults + overrides, checked, defaults filled: each stage reads its section
    config_dir: Path

    @property
    def coupling_path(self) -> Path | None:
        """The coupling spec; None for a robot without couplings."""
        return (self.config_dir / self.settings.coupling).resolve() if self.settings.coupling else None

    def packages(self) -> dict[str, Path]:
        packages = self.settings.packages
        return {
            name: resolve_path(d, self.config_dir, where(packages, str(self.config_dir), name))
            for name, d in packages.items()
        }


PYTHON = "python:"


def resolve_path(value: str, config_dir: Path, at: str) -> Path:
    """A path written in a config: relative to the config's folder, or ``python:NAME/SUB``, found where this Python
    has it (a wheel's data: never copied into a project). NAME is an installed top-level package (its folder), else
    a folder directly in site-packages: wheels such as example-robot-data install data, not packages
    (``python:cmeel.prefix/share/example-robot-data``)."""
    if not value.startswith(PYTHON):
        return (config_dir / value).resolve()
    name, _, sub = value.removeprefix(PYTHON).partition("/")
    folder = _package_folder(name) or _site_folder(name)
    if folder is None:
        raise SvhdescError(
            f"{at}: {value}: no installed Python package or site-packages folder {name!r} (pip install it)"
        )
    return (folder / sub).resolve()


def _package_folder(name: str) -> Path | None:
    """The folder of the top-level package ``name``, located without importing anything (a dotted name would import
    its parent: cmeel's import leaves a temporary folder behind)."""
    if not name.isidentifier():
        return None
    try:
        spec = importlib.util.find_spec(name)
    except (ImportError, ValueError):
        return None
    if spec is None or not spec.submodule_search_locations:
        return None
    return Path(next(iter(spec.submodule_search_locations)))


def _site_folder(name: str) -> Path | None:
    """A folder ``name`` directly in one of this Python's site-packages (purelib, platlib, the user's)."""
    if not name or name in {".", ".."}:
        return None
    paths = sysconfig.get_paths()
    roots = [paths["purelib"], paths["platlib"], *site.getsitepackages(), site.getusersitepackages()]
    return next((Path(r) / name for r in dict.fromkeys(roots) if (Path(r) / name).is_dir()), None)


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


def _merge(base: dict[str, Any], override: dict[str, Any]) -> Node:
    """``override`` over ``base``, section by section; each key keeps the line it was written on."""
    merged = Node(copy.deepcopy(dict(base)))
    merged.where = getattr(override, "where", "") or getattr(base, "where", "")
    merged.lines = {**getattr(base, "lines", {}), **getattr(override, "lines", {})}
    for key, value in override.items():
        if isinstance(value, dict) and isinstance(merged.get(key), dict) and key not in {"keyframes", "grasps", "args"}:
            merged[key] = _merge(merged[key], value)
        else:
            merged[key] = copy.deepcopy(value)
    return merged


def _read(path: Path, chain: tuple[Path, ...] = (), files: list[Path] | None = None) -> dict[str, Any]:
    """The config's mapping with ``extends: BASE`` resolved (the base's variants are not inherited)."""
    data = load_yaml(path)
    if files is not None:
        files.append(path.resolve())
    if not isinstance(data, dict):
        raise SvhdescError(f"{path}: config must be a mapping")
    at = where(data, str(path), "extends")
    base_name = data.pop("extends", None)
    # Checked here: these paths are resolved against this file before any merge.
    if "coupling" in data:
        data["coupling"] = text(data["coupling"], f"{where(data, str(path), 'coupling')}: coupling")
    if "packages" in data:
        data["packages"] = mapping_of(text)(data["packages"], f"{where(data, str(path), 'packages')}: packages")
    if base_name is None:
        return data
    if not isinstance(base_name, str) or not base_name:
        raise SvhdescError(f"{at}: 'extends' must be a file name, got {base_name!r}")
    base_path = (path.parent / base_name).resolve()
    if base_path in chain:
        raise SvhdescError(f"{at}: 'extends' loops back to {base_path}")
    if not base_path.is_file():
        raise SvhdescError(f"{at}: 'extends': no such file {base_path}")
    base = _read(base_path, (*chain, path.resolve()), files)
    base.pop("variants", None)
    # Paths in the base stay relative to the base file.
    for key in ("coupling",):
        if key in base:
            base[key] = str((base_path.parent / base[key]).resolve())
    if "packages" in base:
        packages = base["packages"]
        base["packages"] = Node(
            {k: v if v.startswith(PYTHON) else str((base_path.parent / v).resolve()) for k, v in packages.items()}
        )
        base["packages"].lines = dict(packages.lines)
    return _merge(base, data)


# REP 144: lower case letters, digits and underscores, starting with a letter. A variant is built as a ROS package
# of its name, so its name is one.
PACKAGE_NAME = re.compile(r"^[a-z][a-z0-9_]*$")


def package_name(text: str) -> str:
    """``text`` made a valid package name: lower case, every run of other characters one underscore, a letter first
    (``TwoJointRobot`` -> ``twojointrobot``, ``UF_ROBOT`` -> ``uf_robot``, ``2dof_planar`` -> ``robot_2dof_planar``)."""
    name = re.sub(r"[^a-z0-9_]+", "_", text.lower()).strip("_")
    return name if name[:1].isalpha() else f"robot_{name}".rstrip("_")


def load_config(path: Path) -> Config:
    path = Path(path)
    files: list[Path] = []
    data = _read(path, files=files)
    unknown = [key for key in data if key not in SECTIONS and key != "variants"]
    if unknown:
        at = where(data, str(path), unknown[0])
        raise SvhdescError(f"{at}: unknown top-level key(s) {sorted(map(str, unknown))}")
    if not isinstance(data.get("variants"), dict) or not data["variants"]:
        raise SvhdescError(f"{where(data, str(path), 'variants')}: config needs a non-empty 'variants' mapping")
    defaults = Node({key: value for key, value in data.items() if key != "variants"})
    defaults.where, defaults.lines = where(data, str(path)), dict(getattr(data, "lines", {}))
    variants = {}
    for name, entry in data["variants"].items():
        at = where(entry, where(data["variants"], str(path), name))
        if not PACKAGE_NAME.match(str(name)):
            raise SvhdescError(
                f"{where(data['variants'], str(path), name)}: variant '{name}' is not a valid ROS package name (lower "
                f"case letters, digits and underscores, starting with a letter): rename it, e.g. '{package_name(name)}'"
            )
        if not isinstance(entry, dict) or "xacro" not in entry:
            raise SvhdescError(f"{at}: variant {name} needs an 'xacro' entry point")
        bad = [key for key in entry if key not in VARIANT_KEYS]
        if bad:
            raise SvhdescError(f"{where(entry, at, bad[0])}: variant {name}: unknown key(s) {sorted(map(str, bad))}")
        overrides = Node({k: v for k, v in entry.items() if k not in {"xacro", "args"}})
        overrides.where, overrides.lines = at, dict(getattr(entry, "lines", {}))
        settings = normalise(_merge(defaults, overrides), at)
        xacro = entry["xacro"]
        if not isinstance(xacro, str) or not xacro:
            raise SvhdescError(f"{where(entry, at, 'xacro')}: variant {name}: 'xacro' must be a file name")
        args = entry.get("args") or {}
        if not isinstance(args, dict) or any(isinstance(v, (dict, list)) for v in args.values()):
            raise SvhdescError(f"{where(entry, at, 'args')}: variant {name}: 'args' must map names to values")
        xacro_path = resolve_path(xacro, path.parent, f"{where(entry, at, 'xacro')}: variant {name}: 'xacro'")
        args = {str(k): str(v) for k, v in args.items()}
        variants[str(name)] = Variant(str(name), xacro_path, args, settings, path.parent.resolve())
    return Config(path, variants, tuple(files))
