"""Command line: ``svhdesc build|list|info|validate|render|compare|wireloop|sim|train|play|deploy``.

Bad input: one line on stderr, exit code 2.
"""

from __future__ import annotations

import math
import sys
import warnings
from collections.abc import Callable, Collection
from dataclasses import dataclass, replace
from functools import wraps
from pathlib import Path
from typing import Any

import click

from svhdesc.errors import SvhdescError
from svhdesc.extras import COMMAND_EXTRA, is_optional, missing_message, require_extra
from svhdesc.paths import default_config, default_out, models_dir


def _friendly(func: Callable[..., Any]) -> Callable[..., Any]:
    """Turn SvhdescError into 'error: ...' + exit 2, and warnings into 'warning: ...' lines."""

    @wraps(func)
    def wrapper(*args: Any, **kwargs: Any) -> Any:
        # Each warning is echoed as it comes, never kept: a long-running command (the ROS node, whose
        # rospy warns on every /clock message) must not grow with them. Deprecations are not shown.
        with warnings.catch_warnings():
            warnings.simplefilter("always")
            warnings.simplefilter("ignore", DeprecationWarning)
            warnings.simplefilter("ignore", PendingDeprecationWarning)
            warnings.showwarning = _echo_warning
            try:
                result = func(*args, **kwargs)
            except SvhdescError as exc:
                _error(str(exc))
            except ModuleNotFoundError as exc:
                # An optional dependency this command needs: name the extra, not a traceback.
                if not is_optional(exc):
                    raise
                command = click.get_current_context().command_path.split()
                name = command[1] if len(command) > 1 else command[0]
                _error(missing_message(exc.name or "", f"'svhdesc {name}'", COMMAND_EXTRA.get(name)))
            except OSError as exc:  # safety net: the real checks name the culprit where it is read
                _error(f"{exc.filename or 'file system'}: {exc.strerror or exc}")
            except UnicodeDecodeError as exc:
                _error(f"input is not UTF-8 text ({exc.reason} at byte {exc.start})")
        return result

    return wrapper


def _echo_warning(message: Any, category: Any, *_: Any, **__: Any) -> None:
    click.echo(f"warning: {message}", err=True)


def _error(message: str) -> None:
    # A path that is not UTF-8 must not turn the error line itself into a traceback.
    printable = message.encode("utf-8", "surrogateescape").decode("utf-8", "replace")
    click.echo(f"error: {printable.splitlines()[0] if printable else 'failed'}", err=True)
    sys.exit(2)


# click >= 8.2 raises this for a group run without a command; its message is the whole help text.
NO_ARGS_IS_HELP: Any = getattr(click.exceptions, "NoArgsIsHelpError", ())


class _Group(click.Group):
    """click's own usage errors (unknown option, bad value, missing argument) as the one ``error:`` line too."""

    def main(self, *args: Any, standalone_mode: bool = True, **kwargs: Any) -> Any:
        if not standalone_mode:
            return super().main(*args, standalone_mode=False, **kwargs)
        try:
            result = super().main(*args, standalone_mode=False, **kwargs)
        except NO_ARGS_IS_HELP as exc:  # a group run bare prints its help, as click does
            exc.show()
            sys.exit(exc.exit_code)
        except click.ClickException as exc:
            context = getattr(exc, "ctx", None)
            hint = f" (see '{context.command_path} --help')" if context is not None else ""
            where = f"{context.command_path}: " if context is not None else ""
            _error(f"{where}{' '.join(exc.format_message().split())}{hint}")
        except click.Abort:
            click.echo("Aborted!", err=True)
            sys.exit(1)
        sys.exit(result if isinstance(result, int) else 0)  # what standalone mode does: --help, --version


def _say(message: str, err: bool = False) -> None:
    """A line naming a path: a folder name that is not UTF-8 goes out as the bytes it is, not as a traceback."""
    click.echo(message.encode("utf-8", "surrogateescape"), err=err)


config_option = click.option(
    "--config",
    "config_path",
    type=click.Path(path_type=Path),
    default=None,
    help="Build configuration (default: the repository's config/svhdesc.yaml).",
)
package_option = click.option(
    "--package",
    "packages",
    multiple=True,
    metavar="NAME=DIR",
    help="Resolve $(find NAME) and package://NAME to DIR (repeatable; ROS_PACKAGE_PATH is searched too).",
)


def scene_option(what: str) -> Callable[[Callable[..., Any]], Callable[..., Any]]:
    """``--scene FILE``: one format for sim and plan (svhdesc/sim/objects.py, docs/plan.md)."""
    return click.option(
        "--scene",
        "scene_file",
        type=click.Path(path_type=Path),
        default=None,
        help=f"YAML file whose 'obstacles:' key lists boxes and cylinders (name, shape, size, position; mass, "
        f"friction) {what}; see docs/plan.md.",
    )


def _config_exists(config_path: Path | None) -> None:
    if config_path is not None and not config_path.is_file():
        raise SvhdescError(f"{config_path}: no such config file")


def _load(config_path: Path | None, packages: tuple[str, ...]) -> tuple[Any, dict[str, Path]]:
    from svhdesc.core.settings.config import load_config
    from svhdesc.core.source.packages import package_map, parse_package_option

    _config_exists(config_path)
    config = load_config(config_path or default_config())
    explicit = dict(parse_package_option(p) for p in packages)
    return config, package_map(explicit)


@click.group(cls=_Group)
@click.version_option(package_name="svhdesc")
def main() -> None:
    """svhdesc: compile the SVH hand (and UR5 + SVH) into URDF and MJCF from one source."""


@main.command("build")
@click.argument("variants", nargs=-1)
@click.option(
    "--out",
    type=click.Path(path_type=Path),
    default=None,
    help="Output directory (default: generated/ beside the config's checkout, else beside the config).",
)
@config_option
@package_option
@click.option(
    "--check",
    is_flag=True,
    help="Rebuild into a temporary directory, trusting nothing in OUT nor the hull cache (every collision mesh is "
    "decomposed again); exit 1 listing files that differ.",
)
@click.option(
    "--trust-cache",
    is_flag=True,
    help="With --check: take hulls from the hull cache and the other shipped variants (checked against their meshes, "
    "not recomputed: docs/build.md), in seconds instead of minutes.",
)
@click.option("--jobs", "-j", type=int, default=0, help="Parallel decompositions; 0 (the default): one per CPU.")
@click.option("--rebuild-collisions", is_flag=True, help="Decompose again, ignoring every cache.")
@click.option("--timings", "show_timings", is_flag=True, help="Print wall time per build stage.")
@click.option("--force", is_flag=True, help="Rebuild even if up to date (--check always rebuilds).")
@_friendly
def build_command(
    variants: tuple[str, ...],
    out: Path | None,
    config_path: Path | None,
    packages: tuple[str, ...],
    check: bool,
    trust_cache: bool,
    jobs: int,
    rebuild_collisions: bool,
    show_timings: bool,
    force: bool,
) -> None:
    """Build VARIANTS (all by default) into OUT/<variant>/."""
    from svhdesc.compiler.pipeline.freshness import stale_variants
    from svhdesc.compiler.pipeline.outdir import tidy

    _build_options(jobs, check, trust_cache)
    config, package_dirs = _load(config_path, packages)
    out = out or default_out(config_path)
    selected = config.select(list(variants))
    tidy(out)  # a killed build's staging folder goes even when nothing is to be built
    # Unchanged sources, tools and outputs (by content hash): nothing to build, nothing to import. --check trusts
    # no hash: it always rebuilds and compares.
    stale = selected if force or rebuild_collisions or check else stale_variants(selected, out, package_dirs)
    current = [v.name for v in selected if v not in stale]
    for name in current:
        _say(f"up to date: {out / name}")
    if not stale:
        return

    require_extra("build", "'svhdesc build'")
    from svhdesc.compiler.decompose import HullCache
    from svhdesc.compiler.decompose.source import HullSource, default_cache_dir
    from svhdesc.compiler.pipeline import builder as builder
    from svhdesc.compiler.pipeline.timings import Timings
    from svhdesc.compiler.probes.cache import recomputing

    # The progress bar shows only on a terminal (HullSource checks); CI logs stay quiet. --check trusts no hull it
    # did not compute unless told to: a cache entry can be forged within the fit check's tolerance (docs/build.md).
    recompute = rebuild_collisions or (check and not trust_cache)
    hulls = HullSource(HullCache(default_cache_dir()), jobs=jobs, force=recompute, progress=True)
    timings = Timings()
    run = builder.check if check else builder.build
    with recomputing(check and not trust_cache):  # and the sampled results, like the hulls
        result = run(config, [v.name for v in stale], out, package_dirs, hulls, timings)
    if show_timings:
        _report_timings(timings, hulls.counts)
    if check:
        if result:
            click.echo(f"{len(result)} file(s) differ from {out}:", err=True)
            for line in result:
                _say(f"  {line}", err=True)
            sys.exit(1)
        for variant in stale:
            _say(f"up to date: {out / variant.name} (rebuilt and compared)")
        return
    for name in result:
        _say(f"built {out / name}")


def _report_timings(timings: Any, counts: dict[str, int]) -> None:
    click.echo(timings.report(), err=True)
    click.echo(
        f"collision decompositions: {counts['decomposed']} run, {counts['cached']} from the cache, "
        f"{counts['committed']} from committed outputs",
        err=True,
    )


def _build_options(jobs: int, check: bool, trust_cache: bool) -> None:
    if jobs < 0:
        raise SvhdescError(f"--jobs must be >= 0 (0: one per CPU), got {jobs}")
    if trust_cache and not check:
        raise SvhdescError("--trust-cache goes with --check (a build always takes checked hulls from the cache)")


@main.command("init")
@click.argument("source", type=click.Path(path_type=Path))
@click.option(
    "--out", "out", type=click.Path(path_type=Path), default=None, help="Config to write (default: ROBOT.yaml here)."
)
@package_option
@click.option(
    "--joint",
    "joints",
    multiple=True,
    metavar="NAME.KEY=VALUE",
    help="A quirk of one joint, as joints.NAME.KEY of the config (mimic=drop, mimic=LEADER, effort=, velocity=, "
    "lower=, upper=, damping=, friction=, type=continuous|fixed, servo=velocity): applied to the source and "
    "written into the config.",
)
@_friendly
def init_command(source: Path, out: Path | None, packages: tuple[str, ...], joints: tuple[str, ...]) -> None:
    """Write a commented starter config for the URDF or xacro SOURCE (and, from its <mimic> tags, a coupling spec)."""
    from svhdesc.compiler.starter import starter
    from svhdesc.core.settings.schema import joint_options
    from svhdesc.core.source.packages import parse_package_option

    explicit = dict(parse_package_option(p) for p in packages)
    target = out or Path(f"{source.stem.removesuffix('.urdf')}.yaml")
    result = starter(source, target, explicit, joint_options(joints))
    written = [(target, result.config)]
    if result.coupling is not None:
        written.append((target.with_name(f"{target.stem}.coupling.yaml"), result.coupling))
    for path, text in written:  # each swapped in whole: no partial file on a failure
        path.parent.mkdir(parents=True, exist_ok=True)
        partial = path.with_name(f".{path.name}.partial")
        partial.write_text(text if text.endswith("\n") else text + "\n", encoding="utf-8")
        partial.replace(path)
        _say(f"wrote {path}")


@main.command("list")
@config_option
@_friendly
def list_command(config_path: Path | None) -> None:
    """List the variants the configuration declares."""
    config, _ = _load(config_path, ())
    for name, variant in config.variants.items():
        click.echo(f"{name}\t{variant.xacro.name} {' '.join(f'{k}={v}' for k, v in variant.args.items())}")


@main.command("info")
@click.argument("variant")
@config_option
@package_option
@_friendly
def info_command(variant: str, config_path: Path | None, packages: tuple[str, ...]) -> None:
    """DoF, actuators, masses and the coupling matrix S_m of VARIANT."""
    from svhdesc.compiler.decompose import HullCache
    from svhdesc.compiler.decompose.source import HullSource, default_cache_dir
    from svhdesc.compiler.pipeline.steps import compile_variants
    from svhdesc.compiler.pipeline.timings import Timings
    from svhdesc.core.settings.coupling import coupling_matrix

    config, package_dirs = _load(config_path, packages)
    selected = config.select([variant])[0]
    hulls = HullSource(HullCache(default_cache_dir()))
    hulls.seed_from_outputs([models_dir() / selected.name])
    robot = next(compile_variants(config, [selected.name], package_dirs, hulls, Timings())).robot
    movable = [j for j in robot.joints if j.movable]
    coupled = [j for j in movable if j.mimic]
    click.echo(
        f"{robot.name}: {len(movable)} joints, {len(movable) - len(coupled)} DoF "
        f"({len(coupled)} coupled), {len(robot.actuators)} actuators"
    )
    total = sum(link.inertial.mass for link in robot.links if link.inertial)
    click.echo(f"mass: {total:.4f} kg total")
    for link in robot.links:
        if link.inertial and link.inertial.mass > 1e-3:
            click.echo(f"  {link.name:<28} {link.inertial.mass:9.4f} kg")
    click.echo("actuators:")
    for act in robot.actuators:
        click.echo(f"  {act.name:<36} [{act.lower:+.4f}, {act.upper:+.4f}] rad  {act.effort:g} N m  kp {act.kp:g}")
    rows, cols, matrix = coupling_matrix(robot)
    if rows:
        prefix = f"{robot.hand.prefix}_" if robot.hand.prefix else ""
        short = [c.removeprefix(prefix) for c in cols]
        # Column keys: initials of the channel name (Index_Finger_Distal -> IFD).
        keys = ["".join(part[0] for part in name.split("_")) for name in short]
        click.echo("coupling matrix S_m (joints x channels):")
        click.echo("  " + ", ".join(f"{k} = {name}" for k, name in zip(keys, short)))
        click.echo(" " * 26 + " ".join(f"{k:>8}" for k in keys))
        for name, row in zip(rows, matrix):
            click.echo(f"  {name.removeprefix(prefix):<24}" + " ".join(f"{v:8.5g}" if v else f"{'.':>8}" for v in row))


@main.command("validate")
@click.argument("variants", nargs=-1)
@click.option(
    "--urdf",
    "urdf_path",
    type=click.Path(path_type=Path),
    default=None,
    help="Validate this URDF (with --mjcf) instead of built variants.",
)
@click.option(
    "--mjcf",
    "mjcf_path",
    type=click.Path(path_type=Path),
    default=None,
    help="The MJCF to validate with --urdf.",
)
@click.option(
    "--out",
    type=click.Path(path_type=Path),
    default=None,
    help="Where the built variants are (default: generated/).",
)
@click.option(
    "--json",
    "json_path",
    type=click.Path(path_type=Path),
    default=None,
    help="Also write the full report (every check with its figures) as JSON.",
)
@click.option(
    "--plots",
    type=click.Path(path_type=Path),
    default=None,
    help="Write PNG time series of the contact-stability run to this directory.",
)
@click.option(
    "--checks",
    "checks",
    multiple=True,
    metavar="NAME[,NAME]",
    help="Run only these checks: simulate, coupling_tracking, coupling_spec, urdfdom, yourdfpy, sdformat, "
    "kinematics, mass_budget, inertia, min_mass, mass_agreement, limits, transmissions, semantics, load_limits, "
    "self_collision, gravity_hold, collision_fidelity, range_of_motion, velocity_tracking, contact_stability, "
    "fingertip_force, grasps, batch; or groups: "
    "parsers, mass, coupling, margins, fidelity. Default: all.",
)
@click.option(
    "--samples",
    type=click.IntRange(min=1),
    default=100,
    show_default=True,
    help="Random configurations for the kinematics check.",
)
@click.option(
    "--seed",
    type=int,
    default=0,
    show_default=True,
    help="Seed of every random draw (0: simulate's run is the one the build steps every model through).",
)
@click.option(
    "--vendor-meshes",
    type=click.Path(path_type=Path),
    default=None,
    help="The vendor's schunk_svh_driver folder, whose visual meshes collision_fidelity compares the collision "
    "geometry with (default: ../shared/vendor/schunk_svh_driver beside the checkout).",
)
@click.option(
    "--allow-missing-tools",
    is_flag=True,
    help="Let checks that could not run for want of an external tool (check_urdf, ign sdf) pass; "
    "without it they fail the run. Optional Python extras beyond 'validate' (batch, batch-mjx) need no flag: "
    "what needs one that is not installed is skipped with the reason.",
)
@click.option(
    "--tier",
    type=click.Choice(["static", "full"]),
    default=None,
    help="On robot files (PATH): static, the file's own numbers without simulating (a pre-commit hook's), or full "
    "(the default): static, then compiled by MuJoCo and simulated.",
)
@click.option(
    "--format",
    "output_format",
    type=click.Choice(["text", "json", "github", "junit"]),
    default="text",
    show_default=True,
    help="On robot files: text (file:line: check: message), json, github (workflow annotations) or junit.",
)
@click.option("--select", "select", multiple=True, metavar="NAME[,NAME]", help="On robot files: only these checks.")
@click.option(
    "--ignore", "ignore", multiple=True, metavar="NAME[,NAME]", help="On robot files: leave these checks out."
)
@click.option(
    "--baseline",
    type=click.Path(path_type=Path),
    default=None,
    help="On robot files: findings listed in this file (from --write-baseline) do not fail the run.",
)
@click.option(
    "--write-baseline",
    type=click.Path(path_type=Path),
    default=None,
    help="On robot files: write every finding of this run to FILE as the baseline, and exit 0.",
)
@click.option(
    "--junit", "junit_path", type=click.Path(path_type=Path), default=None, help="On robot files: also write JUnit XML."
)
@click.option(
    "--package",
    "packages",
    multiple=True,
    metavar="NAME=DIR",
    help="On robot files: where package://NAME/ resolves (else ROS_PACKAGE_PATH, then the folders above the file).",
)
@click.option(
    "-j",
    "--jobs",
    type=click.IntRange(1, 256),
    default=1,
    show_default=True,
    help="On robot files: validate this many models at once, each in a process of its own.",
)
@click.option(
    "--arg",
    "xacro_args",
    multiple=True,
    metavar="NAME:=VALUE",
    help="On xacro files: an argument, as xacro takes it (repeat for more).",
)
@config_option
@_friendly
def validate_command(
    variants: tuple[str, ...],
    urdf_path: Path | None,
    mjcf_path: Path | None,
    out: Path | None,
    json_path: Path | None,
    plots: Path | None,
    checks: tuple[str, ...],
    samples: int,
    seed: int,
    vendor_meshes: Path | None,
    allow_missing_tools: bool,
    config_path: Path | None,
    **on_files: Any,  # FileOptions' fields: the options for robot files (PATH)
) -> None:
    """Validate robot files as they stand (PATH: a URDF, an MJCF, a folder), built VARIANTS (all under OUT by
    default) or one --urdf/--mjcf pair.

    On robot files each finding is printed at its file:line with the value that would pass, where one would; exit 0
    when every check passes, 1 on a finding not in --baseline, 2 when a file cannot be read.

    Prints a table per variant (check, measured value, bound, status). Checks that do not apply to a
    robot (no hand, no couplings, no keyframes, ...) are skipped and listed with why. Exit 0 when every
    check that applies passes, 1 when any fails or could not run (see --allow-missing-tools), 2 on bad input.
    Mass bounds come from the configuration declaring the model's variant: --config, else
    config/svhdesc.yaml or the config named in the variant's manifest.json.
    """
    require_extra("validate", "'svhdesc validate'")
    if _validated_as_files(variants, out, urdf_path, FileOptions(**on_files)):
        return
    from svhdesc.validate import Options, built_variants, select_checks, validate_files
    from svhdesc.validate.report import all_passed, render_report, write_json

    selected = select_checks(checks)
    if config_path is not None:  # an explicit config must be good, not silently skipped
        from svhdesc.core.settings.config import load_config

        _config_exists(config_path)
        load_config(config_path)
    pairs = _pairs(variants, urdf_path, mjcf_path) or built_variants(out or models_dir(), variants)
    options = Options(seed=seed, samples=samples, plots=plots)
    if vendor_meshes is not None:
        options = replace(options, vendor_meshes=vendor_meshes)
    reports = []
    for urdf, mjcf in pairs:
        report = validate_files(urdf, mjcf, options, selected, config_path, _stage_line)
        click.echo(render_report(report) + "\n")
        reports.append(report)
    if json_path is not None:
        write_json(reports, json_path, allow_missing_tools)
    failed = [(r.name, [c.name for c in r.failed(allow_missing_tools)]) for r in reports]
    failed = [(name, names) for name, names in failed if names]
    if failed:
        for name, names in failed:
            click.echo(f"{name}: failed: {', '.join(names)}", err=True)
        sys.exit(1)
    click.echo(all_passed(reports))


def _pairs(variants: tuple[str, ...], urdf_path: Path | None, mjcf_path: Path | None) -> list[tuple[Path, Path]]:
    """The --urdf/--mjcf pair, checked; [] without them. A URDF number that is not finite is refused at its
    file:line, as MuJoCo refuses the MJCF's (it would otherwise reach the checks as a nan)."""
    if (urdf_path is None) != (mjcf_path is None):
        raise SvhdescError("--urdf and --mjcf go together")
    if urdf_path is None or mjcf_path is None:
        return []
    if variants:
        raise SvhdescError("give either VARIANTS or --urdf/--mjcf, not both")
    for path in (urdf_path, mjcf_path):
        if not path.is_file():
            raise SvhdescError(f"{path}: no such file")
    from svhdesc.validate.files import read_xml
    from svhdesc.validate.static_urdf import UrdfSource, check_numbers

    for finding in check_numbers(UrdfSource(urdf_path, read_xml(urdf_path), {})):
        raise SvhdescError(f"{finding.where()}: {finding.message}")
    return [(urdf_path, mjcf_path)]


@dataclass(frozen=True)
class FileOptions:
    tier: str | None
    output_format: str
    select: tuple[str, ...]
    ignore: tuple[str, ...]
    baseline: Path | None
    write_baseline: Path | None
    junit_path: Path | None
    packages: tuple[str, ...]
    xacro_args: tuple[str, ...] = ()
    jobs: int = 1

    def given(self) -> bool:
        return any(
            (
                self.tier,
                self.output_format != "text",
                self.select,
                self.ignore,
                self.baseline,
                self.write_baseline,
                self.junit_path,
                self.packages,
                self.xacro_args,
                self.jobs != 1,
            )
        )


def _validated_as_files(
    variants: tuple[str, ...], out: Path | None, urdf_path: Path | None, options: FileOptions
) -> bool:
    """Validate VARIANTS as robot files when they name files; False when they are built variants."""
    if _robot_paths(variants, out, urdf_path) or _settings_name_models(variants, out, urdf_path):
        _validate_robot_files([Path(v) for v in variants], options)
        return True
    if options.given():
        raise SvhdescError(
            "--tier, --format, --select, --ignore, --baseline, --write-baseline, --junit, --package, --arg and --jobs "
            "apply to robot files (PATH), not to built variants"
        )
    return False


def _settings_name_models(variants: tuple[str, ...], out: Path | None, urdf_path: Path | None) -> bool:
    """Whether `svhdesc validate` alone is to validate the models a [tool.svhdesc] table lists."""
    from svhdesc.validate.settings import find_pyproject, load_settings

    if variants or urdf_path is not None or out is not None:
        return False
    pyproject = find_pyproject(Path.cwd())
    if pyproject is None or "[tool.svhdesc" not in pyproject.read_text(encoding="utf-8", errors="replace"):
        return False
    return bool(load_settings().models)


def _robot_paths(variants: tuple[str, ...], out: Path | None, urdf_path: Path | None) -> bool:
    """Whether VARIANTS name robot files or folders of them rather than built variants."""
    if not variants or urdf_path is not None or out is not None:
        return False
    for name in variants:
        path = Path(name)
        if path.is_file() or path.suffix in {".urdf", ".xml", ".xacro"}:
            return True
        if path.is_dir() and not (path / f"{path.name}.xml").is_file():
            return True
    return False


def _check_names(items: tuple[str, ...], known: tuple[str, ...]) -> set[str]:
    names = {part.strip() for item in items for part in item.split(",") if part.strip()}
    for name in sorted(names - set(known)):
        raise SvhdescError(f"unknown check '{name}' (checks on robot files: {', '.join(known)})")
    return names


def _validate_robot_files(paths: list[Path], options: FileOptions) -> None:
    from svhdesc.core.source.packages import parse_package_option
    from svhdesc.validate.files import known_checks
    from svhdesc.validate.findings import apply_baseline, baseline_text, junit, render
    from svhdesc.validate.models import CommandLine, model_runs
    from svhdesc.validate.settings import load_settings

    known = known_checks()
    command_line = CommandLine(
        frozenset(_check_names(options.select, known)),
        frozenset(_check_names(options.ignore, known)),
        dict(parse_package_option(p) for p in options.packages),
        dict(_xacro_arg(a) for a in options.xacro_args),
        options.tier,
    )
    settings = load_settings()
    runs = model_runs(paths or settings.model_files(), settings, command_line, known)
    reports = _run_models(runs, options.jobs)  # all read before any write
    if options.write_baseline is not None:
        _write_atomically(options.write_baseline, baseline_text(reports))
        click.echo(
            f"baseline: {sum(len(c.findings) for r in reports for c in r.checks)} finding(s)"
            f" -> {options.write_baseline}"
        )
        return
    if options.baseline is not None:
        apply_baseline(reports, options.baseline)
    click.echo(render(reports, options.output_format), nl=False)
    if options.junit_path is not None:
        _write_atomically(options.junit_path, junit(reports))
    if any(r.failed for r in reports):
        sys.exit(1)


def _run_models(runs: list[Any], jobs: int) -> list[Any]:
    """Each run's report, in order; with jobs > 1 spread over processes (spawned: no state of this one inherited)."""
    if jobs == 1 or len(runs) < 2:
        return [run.run() for run in runs]
    import multiprocessing
    from concurrent.futures import ProcessPoolExecutor

    from svhdesc.validate.models import run_model

    context = multiprocessing.get_context("spawn")
    with ProcessPoolExecutor(max_workers=min(jobs, len(runs)), mp_context=context) as pool:
        return list(pool.map(run_model, runs))


def _xacro_arg(value: str) -> tuple[str, str]:
    name, sep, given = value.partition(":=")
    if not sep or not name.strip():
        raise SvhdescError(f"--arg {value!r}: expected NAME:=VALUE, as xacro takes arguments")
    return name.strip(), given


def _stage_line(line: str) -> None:
    """A long command's progress: on stderr, so that its output (a table, a report) stays clean."""
    click.echo(f"  {line}", err=True)


@main.command("train")
@click.argument("task_name", metavar="TASK")
@click.option("--device", default="cpu", show_default=True, help="cpu, cuda or cuda:N (Warp's device and torch's).")
@click.option(
    "--envs", type=int, default=None, help="Worlds stepped together (default: the task's on a GPU, 64 on a CPU)."
)
@click.option(
    "--minutes", type=float, default=None, help="Wall-clock budget; training stops after the iteration that ends it."
)
@click.option("--iterations", type=int, default=None, help="PPO iterations at most.")
@click.option(
    "--backend",
    type=click.Choice(["warp", "mujoco"]),
    default="warp",
    show_default=True,
    help="warp: the batch model on MuJoCo Warp, zero-copy; mujoco: the same task in MuJoCo C (CPU development).",
)
@click.option("--out", type=click.Path(path_type=Path), default=None, help="Run folder (default runs/TASK/<time>).")
@click.option("--resume", type=click.Path(path_type=Path), default=None, help="Continue from this checkpoint (.pt).")
@click.option("--seed", type=int, default=0, show_default=True)
@_friendly
def train_command(
    task_name: str,
    device: str,
    envs: int | None,
    minutes: float | None,
    iterations: int | None,
    backend: str,
    out: Path | None,
    resume: Path | None,
    seed: int,
) -> None:
    """Train TASK with PPO (rsl-rl): one progress line per iteration, TensorBoard logs, checkpoints, policy.onnx.

    Tasks: svh_reach, svh_rotate, ur5_lift (docs/learning.md)."""
    from svhdesc.learn.cli_run import run_train

    run_train(task_name, device, envs, minutes, iterations, backend, out, resume, seed, say=_say)


@main.command("play")
@click.argument("task_name", metavar="TASK")
@click.option("--checkpoint", type=click.Path(path_type=Path), required=True, help="policy.onnx or model_N.pt.")
@click.option("--out", type=click.Path(path_type=Path), default=None, help="PNG: a strip of frames of one episode.")
@click.option("--frames", type=int, default=6, show_default=True, help="Frames in the strip.")
@click.option(
    "--source",
    type=click.Choice(["main", "batch"]),
    default="main",
    show_default=True,
    help="main: <variant>.xml (noslip, multi-contact); batch: the model the policy trained on.",
)
@click.option("--backend", type=click.Choice(["mujoco", "warp"]), default="mujoco", show_default=True)
@click.option("--episodes", type=int, default=20, show_default=True, help="Episodes for the success figure (0: none).")
@click.option("--seed", type=int, default=1, show_default=True)
@_friendly
def play_command(
    task_name: str,
    checkpoint: Path,
    out: Path | None,
    frames: int,
    source: str,
    backend: str,
    episodes: int,
    seed: int,
) -> None:
    """Run a trained policy of TASK: its success over EPISODES episodes, and a strip of frames (--out)."""
    from svhdesc.learn.cli_run import run_play

    run_play(task_name, checkpoint, out, frames, source, backend, episodes, seed, say=_say)


@main.command("deploy")
@click.argument("task_name", metavar="TASK")
@click.option("--policy", type=click.Path(path_type=Path), required=True, help="policy.onnx from svhdesc train.")
@click.option("--duration", type=float, default=None, help="Simulated seconds the policy acts (default: one episode).")
@click.option("--seed", type=int, default=1, show_default=True, help="Seed of the task's reset (the start state).")
@click.option(
    "--via",
    type=click.Choice(["trajectory", "forward"]),
    default="trajectory",
    show_default=True,
    help="trajectory: a point per control period on /<controller>/joint_trajectory, nothing switched (SCHUNK's "
    "shipped configuration); forward: switch to the forward position controllers, /<controller>/commands.",
)
@_friendly
def deploy_command(task_name: str, policy: Path, duration: float | None, seed: int, via: str) -> None:
    """Run TASK's policy through the ROS 2 node as on the real hand (needs .venv-ros2, svhdesc[policy]): the
    simulation serves the drivers' interfaces and a tracker in real time, as the hand runs; a policy node drives the
    trajectory controllers (or, --via forward, the forward position controllers). Prints the policy node's measure
    of the episode as one JSON line."""
    import json

    from svhdesc.learn.cli_run import check_seed, positive_seconds
    from svhdesc.learn.deploy import run
    from svhdesc.learn.tasks import task

    chosen = task(task_name)
    positive_seconds("--duration", duration)
    check_seed(seed)
    seconds = duration if duration is not None else chosen.episode_s
    _say(json.dumps(run(chosen, policy, seed, seconds, via), sort_keys=True))


@main.command("render")
@click.argument("variant")
@click.option("--out", "out_file", type=click.Path(path_type=Path), required=True, help="PNG file to write.")
@click.option("--keyframe", default=None, help="Pose to draw (default: 'home' if the model has it).")
@click.option("--size", default="640x480", show_default=True, metavar="WxH", help="Image size in pixels.")
@click.option("--grasp", default=None, help="Draw the hand holding this configured grasp's object instead.")
@_friendly
def render_command(variant: str, out_file: Path, keyframe: str | None, size: str, grasp: str | None) -> None:
    """Render VARIANT's scene.xml offscreen (visual geoms only) to a PNG.

    VARIANT is a built variant's name under generated/, or a variant directory or XML file. The
    picture has a light backdrop, floor and lights (the scene.xml keeps its own for the viewer); the
    camera frames the robot. The OpenGL backend is MUJOCO_GL if set, else EGL, then OSMesa. With
    --grasp, the hand closes that grasp (config 'grasps') on its object, as validate's grasps check
    does, and is drawn holding it. Every picture of docs/: python tools/render_docs.py.
    """
    from svhdesc.validate.render import parse_size, render

    dimensions = parse_size(size)
    target = Path(variant)
    if not target.exists():
        target = models_dir() / variant
        if not target.is_dir():
            raise SvhdescError(f"variant '{variant}' is not built: {target} does not exist")
    if grasp is not None:
        from svhdesc.validate.grasps import render_grasp

        render_grasp(target, grasp, out_file, dimensions)
        click.echo(f"wrote {out_file} ({dimensions[0]}x{dimensions[1]}, grasp {grasp})")
        return
    backend = render(target, out_file, keyframe, dimensions)
    click.echo(f"wrote {out_file} ({dimensions[0]}x{dimensions[1]}, MUJOCO_GL={backend})")


# --- wire-and-loop planner (thesis Appendix A); everything it needs is imported inside the commands ---


@main.group("wireloop")
def wireloop_group() -> None:
    """The wire-and-loop Q-learning planner of the thesis' Appendix A."""


@wireloop_group.command("train")
@click.option("--path", "path", default="training", show_default=True, help="Wire map file or built-in name.")
@click.option("--seed", type=int, default=0, show_default=True)
@click.option("--episodes", type=int, default=50, show_default=True, help="Training episodes per cycle (N_e).")
@click.option("--cycles", type=int, default=200, show_default=True, help="Training cycles at most (N_c).")
@click.option("--out", type=click.Path(path_type=Path), default=Path("wireloop"), show_default=True)
@_friendly
def wireloop_train(path: str, seed: int, episodes: int, cycles: int, out: Path) -> None:
    """Train on a wire; write q_table.json, summary.json and distance.png into OUT."""
    from svhdesc.extras import require
    from svhdesc.wireloop.commands import train_to

    require("matplotlib", "'svhdesc wireloop train'")

    summary = train_to(out, path, seed, episodes, cycles)
    solved = summary["cycles_to_solve"]
    click.echo(
        f"{summary['path']}: {'solved after ' + str(solved) + ' cycles' if solved else 'not solved'} "
        f"in {summary['wall_s']:.3f} s ({summary['episodes_run']} episodes, {summary['states']} states); "
        f"wrote {out}"
    )


@wireloop_group.command("solve")
@click.option("--policy", type=click.Path(path_type=Path), required=True, help="q_table.json from train.")
@click.option("--path", "path", default="training", show_default=True, help="Wire map file or built-in name.")
@click.option("--out", type=click.Path(path_type=Path), default=None, help="Picture (default: next to the policy).")
@_friendly
def wireloop_solve(policy: Path, path: str, out: Path | None) -> None:
    """Run a learned policy greedily along a wire; print the time per action, draw the loop's path."""
    from svhdesc.extras import require
    from svhdesc.wireloop.commands import solve

    require("matplotlib", "'svhdesc wireloop solve'")
    from svhdesc.wireloop.plots import plot_run

    result = solve(policy, path)
    run = result.run
    out = out or policy.parent / f"solve_{result.env.map.name}.png"
    out.parent.mkdir(parents=True, exist_ok=True)
    plot_run(result.env, run.cells, out, f"{result.env.map.name}: {run.outcome} in {run.steps} actions")
    click.echo(
        f"{result.env.map.name}: {run.outcome} after {run.steps} actions, {run.best}/{len(result.env.path_cells) - 1} "
        f"pixels along the wire; {result.per_action_s * 1e6:.2f} us per action "
        f"({result.decide_s * 1e6:.2f} us per decision); wrote {out}"
    )
    if run.outcome != "completed":
        sys.exit(1)


@wireloop_group.command("mujoco")
@click.option("--policy", type=click.Path(path_type=Path), required=True, help="q_table.json from train.")
@click.option("--path", "path", default="training", show_default=True, help="Wire map file or built-in name.")
@click.option("--out", type=click.Path(path_type=Path), default=Path("wireloop"), show_default=True)
@click.option("--actions", type=int, default=None, help="Execute only the plan's first ACTIONS moves.")
@click.option("--no-picture", is_flag=True, help="Skip the rendered picture.")
@_friendly
def wireloop_mujoco(policy: Path, path: str, out: Path, actions: int | None, no_picture: bool) -> None:
    """Execute the greedy plan with the UR5 + SVH in MuJoCo; write mujoco.json and mujoco.png into OUT."""
    from svhdesc.extras import require
    from svhdesc.wireloop.commands import run_mujoco

    require("mujoco", "'svhdesc wireloop mujoco'", "sim")

    report = run_mujoco(policy, path, out, actions, picture=not no_picture)
    click.echo(
        f"{report['path']}: {report['actions']} actions in {report['sim_s']:.2f} s simulated "
        f"({report['wall_s']:.1f} s wall); loop touched the wire: {'YES' if report['touched_wire'] else 'no'}; "
        f"smallest clearance {report['min_clearance_m'] * 1000:.1f} mm; worst tracking error "
        f"{report['worst_position_error_m'] * 1000:.2f} mm, {report['worst_yaw_error_deg']:.2f} deg; wrote {out}"
    )
    if report["touched_wire"] or report["other_wire_contacts"]:
        sys.exit(1)


@main.command("compare")
@click.argument("variant", default="ur5_svh_right")
@click.option(
    "--engines",
    default="mujoco,dart,bullet,drake,ode",
    show_default=True,
    help="Comma-separated engines to run (ode: Gazebo Classic's engine, Debian's python3-pyode).",
)
@click.option(
    "--inertias",
    default="physical,0.001,0.01,0.1",
    show_default=True,
    help="Finger-link inertia settings: 'physical' or a diagonal inertia in kg m^2 (masses stay physical).",
)
@click.option(
    "--duration",
    type=click.FloatRange(min=0, min_open=True),
    default=None,
    help="Simulated seconds per run (default: ramp 1 + settle 2 + record 2 = 5 s; shorter runs scale "
    "settle and record).",
)
@click.option(
    "--window",
    type=click.Choice(["centred", "trailing"]),
    default="centred",
    show_default=True,
    help="Eq. 5.1's 10-sample running average: centred on each sample (the thesis' 'around', MATLAB movmean) "
    "or trailing it.",
)
@click.option(
    "--thesis-setup",
    is_flag=True,
    help="The thesis' conditions: 0.01 kg hand links, Table 4.1's test pose as printed, joint states at 50 Hz, "
    "the vertical component of the contact force.",
)
@click.option("--json", "json_path", type=click.Path(path_type=Path), default=None, help="Write the results as JSON.")
@click.option("--csv", "csv_path", type=click.Path(path_type=Path), default=None, help="Write the results as CSV.")
@click.option(
    "--plots", type=click.Path(path_type=Path), default=None, help="Write joint and force plots to this directory."
)
@_friendly
def compare_command(
    variant: str,
    engines: str,
    inertias: str,
    duration: float | None,
    window: str,
    thesis_setup: bool,
    json_path: Path | None,
    csv_path: Path | None,
    plots: Path | None,
) -> None:
    """Thesis chapter 5 on several engines: press the index fingertip on a surface, measure joint MAD.

    Every engine loads the same generated model (MJCF for MuJoCo, URDF for the others) and runs the
    experiment of `svhdesc validate`'s contact check for each finger-inertia setting. Prints a Markdown
    table like thesis Tables 5.1/5.2. A missing engine is reported, not fatal.
    """
    import svhdesc
    from svhdesc.compare.experiment import Conditions
    from svhdesc.compare.runner import ENGINES, inertia_label, run_grid
    from svhdesc.extras import require

    # MuJoCo places the surface for every engine; matplotlib draws the plots. Both before any run.
    require("mujoco", "'svhdesc compare'", "sim")
    if plots is not None:
        require("matplotlib", "'svhdesc compare --plots'")
    if variant not in svhdesc.variants():
        raise SvhdescError(f"unknown variant '{variant}'; available: {', '.join(svhdesc.variants())}")
    names = _engine_names(engines, ENGINES)
    settings = [_inertia_setting(t.strip()) for t in inertias.split(",")]

    from svhdesc.compare.report import markdown, plot, plot_overview, write_csv, write_json

    def progress(result: Any) -> None:
        extra = f" ({result.note})" if result.note else ""
        click.echo(f"{result.engine} inertia {inertia_label(result.inertia)}: {result.status}{extra}", err=True)

    conditions = Conditions(thesis=thesis_setup, window=window)
    setup, results = run_grid(variant, names, settings, duration, progress, conditions)
    click.echo(markdown(setup, results, variant, conditions))
    if json_path is not None:
        write_json(json_path, variant, setup, results, duration, conditions)
    if csv_path is not None:
        write_csv(csv_path, results)
    if plots is not None:
        overview = plot_overview(results, plots / f"{variant}_compare_force.png")
        for path in [*plot(results, plots, variant), *([overview] if overview else [])]:
            click.echo(f"wrote {path}", err=True)


def _engine_names(engines: str, known: Collection[str]) -> list[str]:
    """`--engines`' comma-separated names, each one of `known`, at least one."""
    names = [n.strip() for n in engines.split(",") if n.strip()]
    unknown = [n for n in names if n not in known]
    if unknown or not names:
        raise SvhdescError(f"--engines: unknown engine '{','.join(unknown)}'; choose from {', '.join(known)}")
    return names


def _inertia_setting(text: str) -> float | None:
    """One `--inertias` entry: None for 'physical', else the positive finger-link inertia it names."""
    if text == "physical":
        return None
    try:
        value = float(text)
    except ValueError:
        value = -1.0
    if not value > 0:
        raise SvhdescError(f"--inertias: '{text}' is neither 'physical' nor a positive number")
    return value


@main.command("sim", context_settings={"ignore_unknown_options": True})
@click.argument("variant")
@click.option("--keyframe", default="home", show_default=True, help="Start pose (a keyframe of the model).")
@click.option("--ros", "use_ros", is_flag=True, help="Run as a ROS 1 node with the real drivers' interfaces.")
@click.option(
    "--ros2",
    "use_ros2",
    is_flag=True,
    help="Run as a ROS 2 (Jazzy) node with the ROS 2 drivers' interfaces (needs .venv-ros2: tools/install.sh ros2).",
)
@click.option(
    "--record",
    type=click.Path(path_type=Path, dir_okay=False),
    default=None,
    metavar="FILE.mcap",
    help="With --ros2: record /clock, /joint_states and the controller states into MCAP (rosbag2's format).",
)
@click.option("--viewer", is_flag=True, help="Show MuJoCo's passive viewer (needs a display).")
@click.option(
    "--duration", type=float, default=None, help="Simulated seconds (default: 1 s; endless with --ros/--viewer)."
)
@click.option("--realtime/--as-fast", default=True, show_default=True, help="Pace to the wall clock, or run flat out.")
@click.option(
    "--track",
    multiple=True,
    metavar="BODY",
    help="Report (with --ros or --ros2: publish on tracked/BODY) this body's pose.",
)
@click.option("--rate", type=float, default=50.0, show_default=True, help="With --ros: /joint_states rate in Hz.")
@click.option(
    "--connector",
    type=click.Path(path_type=Path),
    default=None,
    help="With --ros: the connector YAML (default: the variant's config/connector.yaml).",
)
@scene_option("to add (those with a mass move freely)")
@click.argument("ros_args", nargs=-1, type=click.UNPROCESSED)
@_friendly
def sim_command(
    variant: str,
    keyframe: str,
    use_ros: bool,
    use_ros2: bool,
    record: Path | None,
    viewer: bool,
    duration: float | None,
    realtime: bool,
    track: tuple[str, ...],
    rate: float,
    connector: Path | None,
    scene_file: Path | None,
    ros_args: tuple[str, ...],
) -> None:
    """Simulate VARIANT's scene from KEYFRAME; with --ros (ROS 1) or --ros2 (ROS 2 Jazzy), serve it to ROS like the
    real drivers.

    Trailing NAME:=VALUE arguments are ROS remappings (roslaunch passes __name:= and __log:=; with --ros2 each
    becomes `--ros-args -r NAME:=VALUE`, e.g. __ns:=/left)."""
    if duration is not None and not 0 < duration < math.inf:
        raise SvhdescError(f"--duration must be a positive, finite number of seconds, got {duration}")
    if not 0 < rate < math.inf:
        raise SvhdescError(f"--rate must be a positive, finite number of Hz, got {rate}")
    stray = [a for a in ros_args if ":=" not in a]
    if stray:
        raise SvhdescError(f"unexpected argument(s): {' '.join(stray)}")
    from svhdesc.sim.objects import load_obstacles

    if use_ros and use_ros2:
        raise SvhdescError("--ros and --ros2 exclude each other: one node speaks ROS 1 or ROS 2")
    if record is not None and not use_ros2:
        raise SvhdescError("--record needs --ros2 (it records the ROS 2 node's messages)")
    objects = load_obstacles(scene_file) if scene_file is not None else []
    if use_ros2:
        if connector is not None:
            raise SvhdescError("--connector is a ROS 1 (--ros) option; the ROS 2 node has no connector topics")
        from svhdesc.ros2.node import run_node as run_ros2_node

        run_ros2_node(variant, keyframe, viewer, duration, realtime, list(ros_args), record, objects, track)
        return
    if use_ros:
        from svhdesc.ros1.node import run_node

        run_node(variant, keyframe, viewer, duration, realtime, track, rate, connector, list(ros_args), objects)
        return
    if ros_args:
        raise SvhdescError(f"ROS remappings ({' '.join(ros_args)}) need --ros or --ros2")
    from svhdesc.sim.cli_run import run_plain

    run_plain(variant, keyframe, viewer, duration, realtime, track, click.echo, objects)


@main.command("plan")
@click.argument("variant")
@click.option("--group", required=True, help="SRDF planning group (manipulator, hand, arm_hand).")
@click.option("--from", "start", required=True, help="Start: a group state (home, test) or comma-separated values.")
@click.option("--to", "goal", default=None, help="Goal: a group state or comma-separated values.")
@click.option("--pose", nargs=6, type=float, default=None, help="Goal pose of the tool frame: X Y Z ROLL PITCH YAW.")
@click.option("--planner", default="RRTConnect", show_default=True, help="OMPL planner.")
@click.option("--timeout", type=float, default=5.0, show_default=True, help="Planning time limit (s).")
@scene_option("to plan around")
@click.option("--json", "json_path", type=click.Path(path_type=Path), default=None, help="Write the plan as JSON.")
@click.option("--seed", type=int, default=1, show_default=True, help="OMPL's random seed (same seed, same path).")
@click.option("--execute", is_flag=True, help="Send it to a running 'svhdesc sim --ros' and report tracking error.")
@click.option("--ros2", "over_ros2", is_flag=True, help="With --execute: to a running 'svhdesc sim --ros2' instead.")
@_friendly
def plan_command(
    variant: str,
    group: str,
    start: str,
    goal: str | None,
    pose: tuple[float, ...] | None,
    planner: str,
    timeout: float,
    scene_file: Path | None,
    json_path: Path | None,
    seed: int,
    execute: bool,
    over_ros2: bool,
) -> None:
    """Plan GROUP of VARIANT from a state to a state or a tool pose with OMPL, on its generated MoveIt config."""
    import json

    require_extra("plan", "'svhdesc plan'")
    from svhdesc.plan import PLANNERS, Planner, seed_ompl
    from svhdesc.sim.objects import load_obstacles

    if (goal is None) == (pose is None):
        raise SvhdescError("give exactly one of --to STATE and --pose X Y Z ROLL PITCH YAW")
    if planner not in PLANNERS:
        raise SvhdescError(f"--planner: unknown '{planner}'; choose from {', '.join(PLANNERS)}")
    if not 0 < timeout < math.inf:
        raise SvhdescError(f"--timeout must be a positive, finite number of seconds, got {timeout}")
    if over_ros2 and not execute:
        raise SvhdescError("--ros2 says where --execute sends the plan: give --execute too")
    if json_path is not None and json_path.is_dir():
        raise SvhdescError(f"--json: {json_path} is a directory")
    if variant not in svhdesc_variants():
        raise SvhdescError(f"unknown variant '{variant}'; available: {', '.join(svhdesc_variants())}")
    obstacles = load_obstacles(scene_file) if scene_file is not None else []
    seed_ompl(seed)
    engine = Planner(variant, obstacles)
    result = engine.plan(group, start, goal=goal, pose=pose, planner=planner, timeout=timeout)
    document = result.as_json()
    if result.success and execute:
        document["execution"] = _execute(variant, result, engine.config, over_ros2).as_json()
    if json_path is not None:
        _write_atomically(json_path, json.dumps(document, indent=1) + "\n")
    if not result.success:
        click.echo(f"no plan: {result.message}", err=True)
        sys.exit(1)
    click.echo(
        f"{group}: {len(result.waypoints)} waypoints, {result.path_length:.3f} rad, {result.duration:.2f} s, "
        f"planned in {result.planning_time:.3f} s ({planner})"
    )
    if "execution" in document:
        run_info = document["execution"]
        click.echo(
            f"executed: {'succeeded' if run_info['success'] else 'failed'}, tracking error "
            f"{run_info['max_tracking_error']:.4f} rad max, {run_info['final_error']:.4f} rad at the end"
        )
        if not run_info["success"]:
            sys.exit(1)


def _execute(variant: str, plan: Any, config: Any, over_ros2: bool) -> Any:
    """``plan`` executed over ROS 1 (``svhdesc sim --ros``) or ROS 2 (``svhdesc sim --ros2``)."""
    from svhdesc.plan.execute import execute

    if not over_ros2:
        from svhdesc.plan.ros1 import Ros1

        return execute(plan, config.controllers, Ros1())
    from svhdesc.model import get
    from svhdesc.plan.config import load_ros2_controllers
    from svhdesc.plan.ros2 import Ros2

    controllers = load_ros2_controllers(get(variant).directory, config)
    transport = Ros2(config.joint_names)
    try:
        return execute(plan, controllers, transport)
    finally:
        transport.close()


def _write_atomically(path: Path, text: str) -> None:
    """``path`` holds the old or the new text, never part of it; nothing is left behind if writing fails."""
    if path.is_dir():
        raise SvhdescError(f"{path}: is a folder, not a file to write")
    temporary = path.with_name(path.name + ".tmp")
    try:
        temporary.write_text(text)
        temporary.replace(path)
    except OSError as exc:
        temporary.unlink(missing_ok=True)
        raise SvhdescError(f"{path}: cannot write ({exc.strerror or exc})") from None


@main.command("mjlab", context_settings={"ignore_unknown_options": True})
@click.argument("action", type=click.Choice(["train", "play"]))
@click.argument("task_id", metavar="TASK")
@click.option(
    "--variant", default=None, help="The robot from this built variant (name or folder); default: the task's."
)
@click.argument("args", nargs=-1, type=click.UNPROCESSED)
@_friendly
def mjlab_command(action: str, task_id: str, variant: str | None, args: tuple[str, ...]) -> None:
    """mjlab's own train or play on Svh-Rotate or Ur5-Svh-Lift (needs svhdesc[mjlab]; docs/learning.md)."""
    from svhdesc.mjlab.command import run

    run(action, task_id, variant, args)


def svhdesc_variants() -> list[str]:
    import svhdesc

    return svhdesc.variants()


if __name__ == "__main__":
    main()
