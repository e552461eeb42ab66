"""Build variants into an output directory: atomic, deterministic, with a manifest; or --check it."""

from __future__ import annotations

import tempfile
from pathlib import Path
from typing import Any

from svhdesc.compiler.decompose.source import HullSource
from svhdesc.compiler.export.registry import EXECUTABLE, OUTPUTS, Built, probes_wanted
from svhdesc.compiler.pipeline.agreement import file_difference, manifest_difference
from svhdesc.compiler.pipeline.freshness import portable, sha256, svhdesc_version, tool_versions
from svhdesc.compiler.pipeline.outdir import output_directory, publish, refuse_foreign, require_exchange
from svhdesc.compiler.pipeline.steps import Compiled, compile_variants
from svhdesc.compiler.pipeline.timings import Timings
from svhdesc.compiler.probes import probe
from svhdesc.compiler.probes.cache import committed_results, recording, seeded
from svhdesc.core import manifest as manifest_file
from svhdesc.core.settings.config import Config
from svhdesc.paths import models_dir


def write_variant(
    compiled: Compiled,
    directory: Path,
    config_files: tuple[Path, ...],
    timings: Timings,
    sampled: dict[str, dict[str, Any]] | None = None,
) -> None:
    """The compiled variant's assets, the probes its outputs read, every output of the registry, and the manifest,
    into ``directory``; ``sampled``: the results the variant's build used (``probes.cache.recording``), filled
    until the manifest is written."""
    directory.mkdir(parents=True)
    (directory / "assets").mkdir()
    for name, data in sorted(compiled.assets.files.items()):
        (directory / "assets" / name).write_bytes(data)
    with timings.stage("probes"):
        probed = probe(compiled.robot, compiled.assets, directory / "assets", probes_wanted(compiled.robot))
    built = Built(compiled.robot, compiled.assets, directory, svhdesc_version(), probed)
    for output in OUTPUTS:
        if not output.when(compiled.robot):
            continue
        path = directory / output.name.format(robot=compiled.robot.name)
        with timings.stage(output.stage):
            data = output.export(built)
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_bytes(data)
        if output.executable:
            path.chmod(EXECUTABLE)
    plan = compiled.plan
    inputs = {
        portable(p, plan.packages, plan.variant.config_dir): sha256(p.read_bytes())
        for p in sorted(set(plan.inputs) | set(config_files))
    }
    produced = {
        path.relative_to(directory).as_posix(): sha256(path.read_bytes())
        for path in sorted(directory.rglob("*"))
        if path.is_file()
    }
    hand = compiled.robot.hand
    manifest = {
        "variant": plan.variant.name,
        "hand": {"prefix": hand.prefix, "side": hand.side},  # the contract's Model.hand
        "inputs": inputs,
        "outputs": produced,
        "decompositions": compiled.assets.decompositions,
        "sampled": sampled or {},
        "tools": tool_versions(),
    }
    manifest_file.write(directory, manifest)


def _write_all(
    config: Config,
    names: list[str],
    out: Path,
    directory: Path,
    extra_packages: dict[str, Path],
    hulls: HullSource,
    timings: Timings,
    trust_out: bool = True,
) -> list[str]:
    """Every selected variant into ``directory``/<variant>; ``out`` holds the committed outputs.

    ``trust_out`` False (``--check``): the hulls in ``out`` are under test, so they seed nothing.
    """
    # Hulls are keyed by content (mesh, parameters, CoACD version), so the shipped models' committed hulls serve any
    # build, into any --out; the out's own come last and win.
    shipped = sorted(p for p in models_dir().glob("*") if p.is_dir() and p.parent.resolve() != out.resolve())
    own = [out / v.name for v in config.select(names)] if trust_out else []
    hulls.seed_from_outputs([*shipped, *own])
    manifests = [m for m in (manifest_file.read(d) for d in [*shipped, *own]) if m is not None]
    written: list[str] = []
    with seeded(committed_results(manifests)):  # the sampled results, likewise
        variants = compile_variants(config, names, extra_packages, hulls, timings)
        while True:
            with recording() as sampled:  # the variant's compile (its trial run) and its probes
                compiled = next(variants, None)
                if compiled is None:
                    return written
                write_variant(compiled, directory / compiled.plan.variant.name, config.files, timings, sampled)
            written.append(compiled.plan.variant.name)


def build(
    config: Config,
    names: list[str],
    out: Path,
    extra_packages: dict[str, Path],
    hulls: HullSource,
    timings: Timings | None = None,
) -> list[str]:
    """Build into a staging directory in ``out``, then swap each variant in whole; returns variant names.

    See ``svhdesc.compiler.pipeline.outdir``: one build per ``out`` at a time, crash-safe swaps.
    """
    timings = timings or Timings()
    with output_directory(out) as staging:
        refuse_foreign(out, names)
        require_exchange(staging, out, names)
        variants = _write_all(config, names, out, staging, extra_packages, hulls, timings)
        publish(staging, out, variants)
    return variants


def check(
    config: Config,
    names: list[str],
    out: Path,
    extra_packages: dict[str, Path],
    hulls: HullSource,
    timings: Timings | None = None,
) -> list[str]:
    """Build into a temporary directory and list every file that differs from ``out``.

    Nothing in ``out`` is trusted, its manifest included: its hulls seed nothing (they come from the hull cache,
    whose entries are checked, or from CoACD), so a hand-edited output shows as a difference whatever its
    manifest says.
    """
    timings = timings or Timings()
    with tempfile.TemporaryDirectory(prefix="svhdesc-check-") as tmp:
        fresh = Path(tmp)
        variants = _write_all(config, names, out, fresh, extra_packages, hulls, timings, trust_out=False)
        found = []
        for variant in variants:
            found += differences(fresh / variant, out / variant, variant)
    return found


def differences(new: Path, old: Path, name: str) -> list[str]:
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
