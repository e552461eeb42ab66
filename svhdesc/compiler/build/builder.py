"""Build variants into an output directory: atomic, deterministic, with a manifest; or --check it."""

from __future__ import annotations

import tempfile
from pathlib import Path

from svhdesc.compiler.build import manifest as manifest_file
from svhdesc.compiler.build.agreement import file_difference, manifest_difference
from svhdesc.compiler.build.freshness import portable, sha256, svhdesc_version, tool_versions
from svhdesc.compiler.build.outdir import output_directory, publish
from svhdesc.compiler.build.pipeline import Source, compile_variant, decomposition_plan, read_source
from svhdesc.compiler.build.timings import Timings
from svhdesc.compiler.decompose.source import HullSource
from svhdesc.compiler.export import batch as batch_export
from svhdesc.compiler.export.mjcf import export_mjcf, export_scene
from svhdesc.compiler.export.package import export_package_xml, mesh_uri_prefix
from svhdesc.compiler.export.ros_outputs import EXECUTABLE, ros_outputs
from svhdesc.compiler.export.urdf import export_urdf
from svhdesc.compiler.settings.config import Config, Variant
from svhdesc.compiler.settings.yamlio import where
from svhdesc.compiler.stages.batch_sizing import sample_capacities
from svhdesc.compiler.stages.finite import check_finite
from svhdesc.errors import SvhdescError
from svhdesc.ir import Robot
from svhdesc.paths import models_dir


def write_variant(
    variant: Variant,
    source: Source,
    directory: Path,
    extra_packages: dict[str, Path],
    config_files: tuple[Path, ...],
    hulls: HullSource,
    timings: Timings,
) -> None:
    compiled = compile_variant(variant, extra_packages, hulls, timings, source)
    robot = compiled.robot
    check_finite(robot)
    directory.mkdir(parents=True)
    (directory / "assets").mkdir()
    for name, data in sorted(compiled.assets.files.items()):
        (directory / "assets" / name).write_bytes(data)
    outputs = {
        "package.xml": export_package_xml(robot, svhdesc_version()),
        f"{variant.name}.urdf": export_urdf(robot, mesh_uri_prefix(robot)),
        f"{variant.name}.xml": export_mjcf(robot),
        "scene.xml": export_scene(robot, f"{variant.name}.xml"),
    }
    with timings.stage("export"):
        outputs.update(ros_outputs(robot, outputs[f"{variant.name}.xml"], compiled.assets))
    with timings.stage("batch"):
        outputs.update(batch_outputs(robot, directory / "assets"))
    with timings.stage("export"):
        for name, data in outputs.items():
            (directory / name).parent.mkdir(parents=True, exist_ok=True)
            (directory / name).write_bytes(data)
            if name.startswith("scripts/"):
                (directory / name).chmod(EXECUTABLE)
    packages = {**variant.packages(), **extra_packages}
    inputs = {
        portable(p, packages, variant.config_dir): sha256(p.read_bytes())
        for p in sorted(set(compiled.inputs) | set(config_files))
    }
    produced = {
        path.relative_to(directory).as_posix(): sha256(path.read_bytes())
        for path in sorted(directory.rglob("*"))
        if path.is_file()
    }
    manifest = {
        "variant": variant.name,
        "inputs": inputs,
        "outputs": produced,
        "decompositions": compiled.assets.decompositions,
        "tools": tool_versions(),
    }
    manifest_file.write(directory, manifest)


def batch_outputs(robot: Robot, assets: Path) -> dict[str, bytes]:
    """The batch model and its scene, capacities sized by stepping the unsized model in MuJoCo C."""
    name = batch_export.model_file(robot.name)
    scene = batch_export.export_batch_scene(robot)
    capacities = sample_capacities(scene, name, batch_export.export_batch(robot, None), assets)
    return {name: batch_export.export_batch(robot, capacities), batch_export.SCENE_FILE: scene}


def _prepare(
    config: Config, names: list[str], out: Path, extra_packages: dict[str, Path], hulls: HullSource, timings: Timings
) -> list[tuple[Variant, Source]]:
    """Read every variant, then run all the decompositions they need at once (in parallel)."""
    sources = [(v, read_source(v, extra_packages, timings)) for v in config.select(names)]
    _check_mass_names(config, sources, extra_packages, timings)
    # Hulls are keyed by content (mesh, parameters, CoACD version), so the shipped models' committed hulls serve any
    # build, into any --out; the out's own come last and win.
    shipped = sorted(p for p in models_dir().glob("*") if p.is_dir() and p.parent != out)
    hulls.seed_from_outputs([*shipped, *(out / v.name for v, _ in sources)])
    with timings.stage("decompose"):
        hulls.prefetch([job for v, s in sources for job in decomposition_plan(v, s)])
    return sources


def _check_mass_names(
    config: Config, sources: list[tuple[Variant, Source]], extra_packages: dict[str, Path], timings: Timings
) -> None:
    """mass.links/inertials written in this config may name links of another of its variants (shared
    settings), but not of none."""
    known = {v.name: {link.name for link in s.robot.links} for v, s in sources}

    def links_of(variant: Variant) -> set[str]:
        if variant.name not in known:
            known[variant.name] = {link.name for link in read_source(variant, extra_packages, timings).robot.links}
        return known[variant.name]

    for variant, _ in sources:
        mass = variant.settings["mass"]
        for section in ("links", "inertials"):
            for name in mass[section] if isinstance(mass[section], dict) else ():  # inertials: recompute names none
                at = where(mass[section], str(config.path), name)
                if not at.startswith(f"{config.path}:"):
                    continue  # inherited (extends): a base's shared names may serve variants not declared here
                if name not in links_of(variant) and not any(name in links_of(v) for v in config.variants.values()):
                    raise SvhdescError(f"{at}: mass.{section}: no link {name} in any variant")


def _write_all(
    config: Config,
    names: list[str],
    out: Path,
    directory: Path,
    extra_packages: dict[str, Path],
    hulls: HullSource,
    timings: Timings,
) -> list[Variant]:
    """Every selected variant into ``directory``/<variant>; ``out`` holds the committed outputs."""
    sources = _prepare(config, names, out, extra_packages, hulls, timings)
    for variant, source in sources:
        write_variant(variant, source, directory / variant.name, extra_packages, config.files, hulls, timings)
    return [variant for variant, _ in sources]


def build(
    config: Config,
    names: list[str],
    out: Path,
    extra_packages: dict[str, Path],
    hulls: HullSource,
    timings: Timings | None = None,
) -> list[str]:
    """Build into a staging directory in ``out``, then swap each variant in whole; returns variant names.

    See ``svhdesc.compiler.build.outdir``: one build per ``out`` at a time, crash-safe swaps.
    """
    timings = timings or Timings()
    with output_directory(out) as staging:
        variants = _write_all(config, names, out, staging, extra_packages, hulls, timings)
        publish(staging, out, [v.name for v in variants])
    return [v.name for v in variants]


def check(
    config: Config,
    names: list[str],
    out: Path,
    extra_packages: dict[str, Path],
    hulls: HullSource,
    timings: Timings | None = None,
) -> list[str]:
    """Build into a temporary directory and list every file that differs from ``out``."""
    timings = timings or Timings()
    with tempfile.TemporaryDirectory(prefix="svhdesc-check-") as tmp:
        fresh = Path(tmp)
        variants = _write_all(config, names, out, fresh, extra_packages, hulls, timings)
        differences = []
        for variant in variants:
            differences += _differences(fresh / variant.name, out / variant.name, variant.name)
    return differences


def _differences(new: Path, old: Path, name: str) -> list[str]:
    """Files of a fresh build that do not agree with ``old`` (``agreement``: bytes, or numbers within 1e-10)."""
    new_files = {p.relative_to(new) for p in new.rglob("*") if p.is_file()}
    old_files = {p.relative_to(old) for p in old.rglob("*") if p.is_file()} if old.is_dir() else set()
    differences, tolerated = [], set()
    for rel in sorted(new_files | old_files):
        if rel not in old_files:
            differences.append(f"{name}/{rel} (missing)")
        elif rel not in new_files:
            differences.append(f"{name}/{rel} (stale: the build no longer makes it)")
        elif rel.name != manifest_file.FILE:
            what = file_difference(new / rel, old / rel)
            if what is not None:
                differences.append(f"{name}/{rel} (differs: {what})")
            elif (new / rel).read_bytes() != (old / rel).read_bytes():
                tolerated.add(rel.as_posix())
    if manifest_file.FILE in {p.as_posix() for p in new_files & old_files}:
        what = manifest_difference(manifest_file.path(new), manifest_file.path(old), tolerated)
        if what is not None:
            differences.append(f"{name}/{manifest_file.FILE} (differs: {what})")
    return differences
