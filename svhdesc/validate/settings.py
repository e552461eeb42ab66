"""A repository's own settings for `svhdesc validate PATH` and the pytest plugin: `[tool.svhdesc]` in pyproject.toml.

    [tool.svhdesc]
    models = ["urdf/*.urdf.xacro", "mjcf/scene*.xml"]    # what `svhdesc validate` alone and `pytest` validate
    packages = { my_robot_description = "." }            # package://NAME and $(find NAME), relative to this file
    ignore = { meshes = "the meshes are in a submodule CI does not fetch" }   # check = reason
    tier = "full"                                        # or "static" (the command line's --tier wins)

    [tool.svhdesc.model."urdf/arm.urdf.xacro"]            # one model (a glob), its own settings on top
    args = { side = ["left", "right"], gripper = "true" }  # a list: one model per choice, as pal's urdf_test
    pose = { shoulder = 0.5, elbow = -1.2 }              # a URDF's rest pose: settle and contacts are judged there
    ignore = { inertials = "the base is welded to the world" }
    keyframe = "home"                                    # an MJCF's rest pose: its keyframe of that name, not 0
    joints.gripper = { tolerance = 0.002, effort = 20, ignore = { range_of_motion = "a cam the model omits" } }

An svhdesc.yaml beside a model may add a ``validate:`` section with the same keys as a model's table (args,
packages, select, ignore, pose, keyframe, joints); it applies to every model in its folder, on top of pyproject.toml's.

Read where it is used, with every fault one error naming the file and the line of the key.
"""

from __future__ import annotations

import fnmatch
import itertools
import math
import re
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from svhdesc.errors import SvhdescError
from svhdesc.validate.quirks import JointSettings

_TOP_KEYS = {"models", "packages", "select", "ignore", "model", "tier"}
TIERS = ("static", "full")
_MODEL_KEYS = {"args", "packages", "select", "ignore", "pose", "keyframe", "joints"}
_JOINT_KEYS = {"effort", "tolerance", "ignore"}
JOINT_CHECKS = ("gravity_hold", "range_of_motion")  # the checks a joint's settings may leave it out of


@dataclass(frozen=True)
class ModelSettings:
    """What applies to one model: xacro argument choices, packages, checks selected, checks ignored with why."""

    args: Mapping[str, tuple[str, ...]] = field(default_factory=dict)
    packages: Mapping[str, Path] = field(default_factory=dict)
    select: tuple[str, ...] = ()
    ignore: Mapping[str, str] = field(default_factory=dict)
    # a URDF's rest pose (joint = position): the pose it states, where the full tier settles and judges contacts
    pose: Mapping[str, float] = field(default_factory=dict)
    keyframe: str | None = None  # an MJCF's rest pose: its keyframe of this name (else keyframe 0)
    joints: Mapping[str, JointSettings] = field(default_factory=dict)


@dataclass(frozen=True)
class RepoSettings:
    file: Path | None  # the pyproject.toml read, None without one
    models: tuple[str, ...] = ()
    common: ModelSettings = ModelSettings()
    per_model: tuple[tuple[str, ModelSettings], ...] = ()
    tier: str | None = None  # static or full; the command line's --tier wins

    @property
    def root(self) -> Path:
        return self.file.parent if self.file else Path.cwd()

    def for_model(self, path: Path) -> ModelSettings:
        """The common settings, those of every [tool.svhdesc.model."GLOB"] matching ``path`` on top, and those of
        the ``validate:`` section of an svhdesc.yaml beside the model on top of all."""
        relative = _relative_to(path, self.root)
        merged = self.common
        for pattern, settings in self.per_model:
            if relative is not None and fnmatch.fnmatch(relative, pattern):
                merged = _merged(merged, settings)
        beside = beside_settings(path)
        return _merged(merged, beside) if beside is not None else merged

    def model_files(self) -> list[Path]:
        """The files ``models`` names, in order, each once; a pattern matching nothing is an error."""
        found: list[Path] = []
        for pattern in self.models:
            matched = sorted(p for p in self.root.glob(pattern) if p.is_file())
            if not matched:
                raise SvhdescError(f"{self._where('models')}: '{pattern}' matches no file under {self.root}")
            found.extend(p for p in matched if p not in found)
        return found

    def _where(self, key: str) -> str:
        return _where(self.file, key) if self.file else "[tool.svhdesc]"


def _merged(under: ModelSettings, over: ModelSettings) -> ModelSettings:
    return ModelSettings(
        {**under.args, **over.args},
        {**under.packages, **over.packages},
        over.select or under.select,
        {**under.ignore, **over.ignore},
        {**under.pose, **over.pose},
        over.keyframe or under.keyframe,
        {**under.joints, **over.joints},
    )


def beside_settings(model: Path) -> ModelSettings | None:
    """The ``validate:`` section of svhdesc.yaml in the model's folder (args, packages, select, ignore, as a
    [tool.svhdesc.model] table), for every model there; None without one. A build config of the same name has no
    such section and is not read as one."""
    file = model.parent / "svhdesc.yaml"
    if not file.is_file():
        return None
    import yaml

    try:
        document = yaml.safe_load(file.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError) as exc:
        raise SvhdescError(f"{file}: cannot be read ({exc})") from None
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        where = f"{file}:{mark.line + 1}" if mark is not None else str(file)
        raise SvhdescError(f"{where}: not valid YAML ({getattr(exc, 'problem', exc)})") from None
    if not isinstance(document, dict) or "validate" not in document:
        return None
    section = _keys(file, document["validate"], _MODEL_KEYS, "validate")
    return _model_settings(file, section, "validate")


def _relative_to(path: Path, root: Path) -> str | None:
    try:
        return path.resolve().relative_to(root.resolve()).as_posix()
    except ValueError:
        return None


def _where(file: Path, key: str, section: str = "tool.svhdesc") -> str:
    """``file:line`` of the first line assigning ``key`` in ``section`` (a table's name, or a model's glob), else of
    the section's header (tomllib keeps no lines of what it read)."""
    try:
        lines = file.read_text(encoding="utf-8", errors="replace").splitlines()
    except OSError:
        return str(file)
    is_header = re.compile(rf"\s*\[.*{re.escape(section)}|{re.escape(section)}\s*:")  # TOML [table], YAML key:
    header = next((n for n, line in enumerate(lines) if is_header.match(line)), 0)
    assigns = re.compile(rf'\s*"?{re.escape(key)}"?\s*[=:]|.*[{{,]\s*"?{re.escape(key)}"?\s*[=:]')
    found = next((n for n in range(header, len(lines)) if assigns.match(lines[n])), header)
    return f"{file}:{found + 1}"


def find_pyproject(start: Path) -> Path | None:
    """The nearest pyproject.toml at or above ``start`` (as ruff and pytest find theirs)."""
    start = start.resolve()
    for folder in [start, *start.parents]:
        if (folder / "pyproject.toml").is_file():
            return folder / "pyproject.toml"
    return None


def load_settings(start: Path | None = None) -> RepoSettings:
    """The [tool.svhdesc] table of the nearest pyproject.toml, checked; empty settings without one."""
    file = find_pyproject(start or Path.cwd())
    if file is None:
        return RepoSettings(None)
    try:
        import tomllib
    except ModuleNotFoundError:  # Python 3.10
        import tomli as tomllib  # type: ignore[no-redef]
    try:
        document = tomllib.loads(file.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError) as exc:
        raise SvhdescError(f"{file}: cannot be read ({exc})") from None
    except tomllib.TOMLDecodeError as exc:
        line = re.search(r"line (\d+)", str(exc))
        raise SvhdescError(f"{file}{':' + line.group(1) if line else ''}: not valid TOML ({exc})") from None
    table = document.get("tool", {}).get("svhdesc")
    if table is None:
        return RepoSettings(file)
    return _settings(file, table)


def _settings(file: Path, table: Any) -> RepoSettings:
    top = "tool.svhdesc"
    _keys(file, table, _TOP_KEYS, top)
    models = _strings(file, "models", table.get("models", []), top)
    tier = table.get("tier")
    if tier is not None and tier not in TIERS:
        raise SvhdescError(f"{_where(file, 'tier')}: 'tier' must be one of {', '.join(TIERS)}, not {tier!r}")
    per_model = table.get("model", {})
    if not isinstance(per_model, dict):
        raise SvhdescError(f"{_where(file, 'model')}: [tool.svhdesc.model] must be a table of GLOB = {{...}}")
    return RepoSettings(
        file,
        tuple(models),
        _model_settings(file, table, top),
        tuple(
            (glob, _model_settings(file, _keys(file, value, _MODEL_KEYS, _section(glob)), _section(glob)))
            for glob, value in per_model.items()
        ),
        tier,
    )


def _section(glob: str) -> str:
    return f'tool.svhdesc.model."{glob}"'


def _keys(file: Path, table: Any, allowed: set[str], section: str) -> dict[str, Any]:
    if not isinstance(table, dict):
        raise SvhdescError(f"{_where(file, '', section)}: [{section}] must be a table")
    for unknown in sorted(set(table) - allowed):
        known = ", ".join(sorted(allowed))
        raise SvhdescError(f"{_where(file, unknown, section)}: unknown key '{unknown}' in [{section}] (known: {known})")
    return table


def _strings(file: Path, key: str, value: Any, section: str) -> list[str]:
    if not isinstance(value, list) or not all(isinstance(v, str) and v for v in value):
        raise SvhdescError(f"{_where(file, key, section)}: '{key}' in [{section}] must be a list of non-empty strings")
    return value


def _model_settings(file: Path, table: dict[str, Any], section: str) -> ModelSettings:
    from svhdesc.validate.files import known_checks

    known = known_checks()
    select = _strings(file, "select", table.get("select", []), section)
    ignore = table.get("ignore", {})
    if not isinstance(ignore, dict) or not all(isinstance(v, str) and v.strip() for v in ignore.values()):
        where = _where(file, "ignore", section)
        raise SvhdescError(f"{where}: 'ignore' in [{section}] must be a table of CHECK = \"reason\"")
    for check, key in [*((c, "select") for c in select), *((c, c) for c in ignore)]:
        if check not in known:
            where, listed = _where(file, key, section), ", ".join(known)
            raise SvhdescError(f"{where}: unknown check '{check}' (checks on robot files: {listed})")
    return ModelSettings(
        _args(file, table.get("args", {}), section),
        _packages(file, table.get("packages", {}), section),
        tuple(select),
        ignore,
        _pose(file, table.get("pose", {}), section),
        _keyframe(file, table.get("keyframe"), section),
        _joints(file, table.get("joints", {}), section),
    )


def _keyframe(file: Path, value: Any, section: str) -> str | None:
    if value is not None and not (isinstance(value, str) and value):
        where = _where(file, "keyframe", section)
        raise SvhdescError(f"{where}: 'keyframe' in [{section}] must be a keyframe's name, not {value!r}")
    return value


def _joints(file: Path, value: Any, section: str) -> dict[str, JointSettings]:
    if not isinstance(value, dict):
        where = _where(file, "joints", section)
        raise SvhdescError(f"{where}: 'joints' in [{section}] must be a table of JOINT = {{effort, tolerance, ignore}}")
    return {str(name): _joint(file, name, quirks, section) for name, quirks in value.items()}


def _joint(file: Path, name: str, quirks: Any, section: str) -> JointSettings:
    _keys(file, quirks, _JOINT_KEYS, f"{section}.joints.{name}")
    numbers = {}
    for key in ("effort", "tolerance"):
        value = quirks.get(key)
        if value is not None and not (_number(value) and value > 0):
            where = _where(file, key, section)
            raise SvhdescError(f"{where}: joint '{name}': '{key}' must be a number > 0, not {value!r}")
        numbers[key] = float(value) if value is not None else None
    ignore = quirks.get("ignore", {})
    if not isinstance(ignore, dict) or not all(isinstance(v, str) and v.strip() for v in ignore.values()):
        where = _where(file, "ignore", section)
        raise SvhdescError(f"{where}: joint '{name}': 'ignore' must be a table of CHECK = \"reason\"")
    for check in ignore:
        if check not in JOINT_CHECKS:
            where = _where(file, check, section)
            raise SvhdescError(
                f"{where}: joint '{name}': a joint may be left out of {' or '.join(JOINT_CHECKS)}, not '{check}'"
            )
    return JointSettings(numbers["effort"], numbers["tolerance"], dict(ignore))


def _number(value: Any) -> bool:
    return isinstance(value, int | float) and not isinstance(value, bool) and math.isfinite(value)


def _pose(file: Path, value: Any, section: str) -> dict[str, float]:
    numbers = isinstance(value, dict) and all(
        isinstance(v, int | float) and not isinstance(v, bool) and math.isfinite(v) for v in value.values()
    )
    if not numbers:
        where = _where(file, "pose", section)
        raise SvhdescError(f"{where}: 'pose' in [{section}] must be a table of JOINT = a finite position")
    return {str(k): float(v) for k, v in value.items()}


def _args(file: Path, value: Any, section: str) -> dict[str, tuple[str, ...]]:
    if not isinstance(value, dict):
        where = _where(file, "args", section)
        raise SvhdescError(f"{where}: 'args' in [{section}] must be a table of NAME = VALUE or [VALUES]")
    args = {}
    for arg, given in value.items():
        choices = given if isinstance(given, list) else [given]
        if not choices or not all(isinstance(c, str | bool | int | float) for c in choices):
            where = _where(file, arg, section)
            raise SvhdescError(f"{where}: xacro argument '{arg}' must be a value or a list of values")
        args[arg] = tuple(str(c).lower() if isinstance(c, bool) else str(c) for c in choices)
    return args


def _packages(file: Path, value: Any, section: str) -> dict[str, Path]:
    if not isinstance(value, dict) or not all(isinstance(v, str) for v in value.values()):
        raise SvhdescError(f"{_where(file, 'packages', section)}: 'packages' must be a table of NAME = \"folder\"")
    packages = {}
    for name, folder in value.items():
        path = (file.parent / folder).resolve()
        if not path.is_dir():
            raise SvhdescError(f"{_where(file, name, section)}: package '{name}': folder {folder} does not exist")
        packages[name] = path
    return packages


def arg_combinations(args: Mapping[str, tuple[str, ...]]) -> list[dict[str, str]]:
    """One dict per combination of the arguments' choices ([{}] without arguments)."""
    names = sorted(args)
    return [dict(zip(names, values)) for values in itertools.product(*(args[n] for n in names))]


def label(path: str, args: Mapping[str, str], all_args: Mapping[str, tuple[str, ...]]) -> str:
    """``arm.urdf.xacro[side=left]``: the arguments that vary between a model's combinations."""
    varying = [f"{n}={args[n]}" for n in sorted(args) if len(all_args.get(n, ())) > 1]
    return f"{path}[{','.join(varying)}]" if varying else path
