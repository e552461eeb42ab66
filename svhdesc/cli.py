"""Command line: ``svhdesc build|list|info``. Bad input: one line on stderr, exit code 2."""

from __future__ import annotations

import sys
import warnings
from collections.abc import Callable
from functools import wraps
from pathlib import Path
from typing import Any

import click

from .errors import SvhdescError
from .paths import DEFAULT_CONFIG, default_out


def _friendly(func: Callable[..., Any]) -> Callable[..., Any]:
    """Turn SvhdescError into 'error: ...' + exit 2, and warnings into 'warning: ...' lines."""

    @wraps(func)
    def wrapper(*args: Any, **kwargs: Any) -> Any:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            try:
                result = func(*args, **kwargs)
            except SvhdescError as exc:
                click.echo(f"error: {exc}", err=True)
                sys.exit(2)
            finally:
                for warning in caught:
                    if not issubclass(warning.category, (DeprecationWarning, PendingDeprecationWarning)):
                        click.echo(f"warning: {warning.message}", err=True)
        return result

    return wrapper


config_option = click.option(
    "--config", "config_path", type=click.Path(path_type=Path), default=None,
    help="Build configuration (default: the repository's config/svhdesc.yaml).",
)
package_option = click.option(
    "--package", "packages", multiple=True, metavar="NAME=DIR",
    help="Resolve $(find NAME) and package://NAME to DIR (repeatable; ROS_PACKAGE_PATH is searched too).",
)


def _load(config_path: Path | None, packages: tuple[str, ...]) -> tuple[Any, dict[str, Path]]:
    from .config import load_config
    from .packages import package_map, parse_package_option

    config = load_config(config_path or DEFAULT_CONFIG)
    explicit = dict(parse_package_option(p) for p in packages)
    return config, package_map(explicit)


@click.group()
@click.version_option(package_name="svhdesc")
def main() -> None:
    """svhdesc: compile the SVH hand (and UR5 + SVH) into URDF and MJCF from one source."""


@main.command("build")
@click.argument("variants", nargs=-1)
@click.option("--out", type=click.Path(path_type=Path), default=None, help="Output directory (default: generated/).")
@config_option
@package_option
@click.option("--check", is_flag=True, help="Build to a temporary directory; exit 1 listing files that differ.")
@_friendly
def build_command(variants: tuple[str, ...], out: Path | None, config_path: Path | None,
                  packages: tuple[str, ...], check: bool) -> None:
    """Build VARIANTS (all by default) into OUT/<variant>/."""
    from . import build as builder

    config, package_dirs = _load(config_path, packages)
    out = out or default_out()
    if check:
        differences = builder.check(config, list(variants), out, package_dirs)
        if differences:
            click.echo(f"{len(differences)} file(s) differ from {out}:", err=True)
            for line in differences:
                click.echo(f"  {line}", err=True)
            sys.exit(1)
        click.echo(f"up to date: {out}")
        return
    built = builder.build(config, list(variants), out, package_dirs)
    for name in built:
        click.echo(f"built {out / name}")


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
    from .coupling import coupling_matrix
    from .pipeline import compile_variant

    config, package_dirs = _load(config_path, packages)
    robot = compile_variant(config.select([variant])[0], package_dirs).robot
    movable = [j for j in robot.joints if j.movable]
    coupled = [j for j in movable if j.mimic]
    click.echo(f"{robot.name}: {len(movable)} joints, {len(movable) - len(coupled)} DoF "
               f"({len(coupled)} coupled), {len(robot.actuators)} actuators")
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
        prefix = robot.channels[0].joint[: -len(robot.channels[0].name)]
        short = [c.removeprefix(prefix) for c in cols]
        click.echo("coupling matrix S_m (joints x channels):")
        click.echo(" " * 26 + " ".join(f"{c[:8]:>8}" for c in short))
        for name, row in zip(rows, matrix):
            click.echo(f"  {name.removeprefix(prefix):<24}" + " ".join(f"{v:8.4g}" if v else f"{'.':>8}" for v in row))


if __name__ == "__main__":
    main()
