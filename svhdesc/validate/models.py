"""The models one `svhdesc validate PATH` run (or one pytest session) validates: each file, once per combination of its
xacro arguments, with the packages, checks and ignores that the command line and [tool.svhdesc] give it."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path

from svhdesc.validate.file_parsers import PARSER_CHECKS
from svhdesc.validate.files import STATIC_MJCF_CHECKS, is_xacro, robot_files, root_tag, validate_file
from svhdesc.validate.findings import CheckResult, FileReport
from svhdesc.validate.full_checks import FULL_CHECKS
from svhdesc.validate.quirks import JointSettings, Quirks
from svhdesc.validate.settings import RepoSettings, arg_combinations, label
from svhdesc.validate.static_urdf import RULES


@dataclass(frozen=True)
class CommandLine:
    """What the command line says; it wins over the settings file."""

    select: frozenset[str] = frozenset()
    ignore: frozenset[str] = frozenset()
    packages: Mapping[str, Path] = field(default_factory=dict)
    args: Mapping[str, str] = field(default_factory=dict)
    tier: str | None = None


@dataclass(frozen=True)
class ModelRun:
    path: Path
    walked: bool
    label: str
    args: Mapping[str, str]
    packages: Mapping[str, Path]
    selected: frozenset[str]
    ignored: Mapping[str, str]  # check -> the reason the settings give
    tier: str = "full"
    pose: Mapping[str, float] = field(default_factory=dict)  # a URDF's rest pose, from the settings
    keyframe: str | None = None  # an MJCF's rest pose, from the settings
    joints: Mapping[str, JointSettings] = field(default_factory=dict)  # joints' quirks, from the settings

    def checks(self) -> list[str]:
        """The checks this run reports, in order, known before it runs (the pytest plugin's items)."""
        return [c for c in ("xml", *_kind_checks(self.path, self.tier)) if c in self.selected]

    def run(self) -> FileReport:
        selected = set(self.selected) - set(self.ignored)
        quirks = Quirks(dict(self.pose), self.keyframe, dict(self.joints))
        report = validate_file(
            self.path, selected, dict(self.packages), self.walked, dict(self.args), self.tier, quirks
        )
        report.path = self.label
        for check, reason in self.ignored.items():
            if check in self.selected:
                report.checks.append(CheckResult(check, "skipped", reason=f"ignored in [tool.svhdesc]: {reason}"))
        order = {name: i for i, name in enumerate(self.checks())}
        report.checks.sort(key=lambda c: order.get(c.name, len(order)))
        return report


def _kind_checks(path: Path, tier: str) -> tuple[str, ...]:
    urdf = (*RULES, *PARSER_CHECKS, *(("mujoco_compile", *FULL_CHECKS) if tier == "full" else ()))
    mjcf = (*STATIC_MJCF_CHECKS, *(FULL_CHECKS if tier == "full" else ()))
    if is_xacro(path) or path.suffix == ".urdf":
        return urdf
    tag = root_tag(path)
    return () if tag is None else urdf if tag == "robot" else mjcf


def model_runs(
    paths: list[Path], settings: RepoSettings, command_line: CommandLine, known: tuple[str, ...]
) -> list[ModelRun]:
    """Every model to validate: each robot file of ``paths`` (folders walked) per combination of xacro arguments."""
    runs = []
    for path, walked in robot_files(paths):
        own = settings.for_model(path)
        choices = {**own.args, **{name: (value,) for name, value in command_line.args.items()}}
        selected = set(command_line.select or own.select or known) - command_line.ignore
        for args in arg_combinations(choices) if is_xacro(path) else [{}]:
            runs.append(
                ModelRun(
                    path,
                    walked,
                    label(str(path), args, choices),
                    args,
                    {**own.packages, **command_line.packages},
                    frozenset(selected),
                    {c: r for c, r in own.ignore.items() if c not in command_line.select},
                    command_line.tier or settings.tier or "full",
                    own.pose,
                    own.keyframe,
                    own.joints,
                )
            )
    return runs


def run_model(run: ModelRun) -> FileReport:
    """``run.run()`` as a module-level function, which a process pool can send to a worker."""
    return run.run()
