"""Shared helpers for the tests: the one session build (`built()`), the one CLI runner, `fails_cleanly`, `exported`."""

from __future__ import annotations

import fcntl
import functools
import json
import os
import signal
import subprocess
import sys
import tempfile
import traceback
from pathlib import Path
from typing import Any

import pytest

from svhdesc.core.settings.config import load_config

TESTS = Path(__file__).resolve().parent
REPO = TESTS.parent
SHARED = REPO.parent / "shared"
VENDOR_SVH = SHARED / "vendor" / "schunk_svh_driver"
VENDOR_UR = SHARED / "vendor" / "ur_description"
# The --check runs that rebuild the hand: one worker, the cold one first, so they share its decompositions.
HULL_CHECK = pytest.mark.xdist_group("hull_check")
# From the config, not a copy of it: a variant added there is tested everywhere.
VARIANTS = tuple(load_config(REPO / "config" / "svhdesc.yaml").variants)


def run_cli(
    *args: str,
    cwd: Path = REPO,
    env: dict[str, str] | None = None,
    python: str = sys.executable,
    timeout: float = 600,
    in_process: bool = False,
) -> subprocess.CompletedProcess[str]:
    """``svhdesc ARGS`` in a subprocess of ``python`` (``env`` adds to the inherited environment), or with
    ``in_process`` through click's runner in this process: no interpreter start, for the many runs that fail early,
    and for validate's runs, which then share the worker's imports (JAX and MJX, Warp: about 10 s of CPU a process).
    An uncaught exception ends the in-process run with 1 and its traceback on stderr, as it ends the CLI."""
    if in_process:
        from click.testing import CliRunner

        from svhdesc.cli import main

        assert cwd == REPO and python == sys.executable, "in-process runs take no cwd or python"
        result = CliRunner().invoke(main, list(args), env=env)  # env: set for the call, then restored
        stderr = result.stderr
        if result.exc_info is not None and not isinstance(result.exception, SystemExit):
            stderr += "".join(traceback.format_exception(*result.exc_info))
        return subprocess.CompletedProcess(args, result.exit_code, result.stdout, stderr)
    return subprocess.run(
        [python, "-m", "svhdesc.cli", *args],
        cwd=cwd,
        capture_output=True,
        text=True,
        timeout=timeout,
        env={**os.environ, **(env or {})},
    )


def snapshot(directory: Path) -> dict[str, bytes | None]:
    """Every path under ``directory`` (folders as None), with its bytes."""
    return {
        p.relative_to(directory).as_posix(): p.read_bytes() if p.is_file() else None
        for p in sorted(directory.rglob("*"))
    }


def fails_cleanly(out: Path | None, *args: str, match: str) -> str:
    """``svhdesc ARGS`` (in process) exits 2 with exactly one ``error:`` line, which names ``match``, and no
    traceback; ``out``, if it exists, is left as it was (no file changed, none added, no temporary leftovers)."""
    before = snapshot(out) if out is not None and out.is_dir() else None
    result = run_cli(*args, in_process=True)
    errors = [line for line in result.stderr.splitlines() if line.startswith("error:")]
    assert result.returncode == 2, (result.returncode, result.stderr)  # 1: an uncaught exception
    assert len(errors) == 1 and "Traceback" not in result.stderr, result.stderr
    assert match in errors[0], errors[0]
    if before is not None:
        assert snapshot(out) == before  # type: ignore[arg-type]
    return errors[0]


@functools.cache
def built() -> Path:
    """A fresh build of every variant from the sources alone, shared by the whole run: every collision mesh
    decomposed again and every result the build samples in MuJoCo sampled again, as ``build --check`` does, nothing
    seeded from generated/ or taken from a cache (tests/compiler/pipeline/test_check.py compares it with
    generated/: the run's one decomposition of the shipped meshes). The first xdist worker to ask (or
    ``start_build``'s background process) builds it under the run's folder (tests/conftest.py), the others wait for
    it and read it; ``build_counts()`` says where its hulls came from."""
    run = Path(os.environ.get("SVHDESC_TEST_RUN") or tempfile.mkdtemp(prefix="svhdesc-test-run-"))
    out, done = run / "build", run / BUILD_DONE
    with open(run / "build.lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        if not done.exists():
            (run / BUILD_COUNTS).write_text(json.dumps(_build_afresh(out)))
            done.touch()
    return out


def build_counts() -> dict[str, int]:
    """The session build's hulls by origin: decomposed, from the cache, from committed outputs."""
    built()
    return json.loads((Path(os.environ["SVHDESC_TEST_RUN"]) / BUILD_COUNTS).read_text())


def _build_afresh(out: Path) -> dict[str, int]:
    """``svhdesc build --out OUT --rebuild-collisions`` with the sampled results recomputed too (what ``build --check``
    trusts), through the builder: the hulls' counts come back."""
    from svhdesc.compiler.decompose import HullCache
    from svhdesc.compiler.decompose.source import HullSource, default_cache_dir
    from svhdesc.compiler.pipeline import builder
    from svhdesc.compiler.probes.cache import recomputing

    config = load_config(REPO / "config" / "svhdesc.yaml")
    fresh = os.environ.get(FRESH_BUILD, "1") == "1"
    hulls = HullSource(HullCache(default_cache_dir()), force=fresh)
    if not fresh:
        hulls.seed_from_outputs(sorted(p for p in (REPO / "generated").iterdir() if p.is_dir()))
    with recomputing(fresh):
        builder.build(config, list(config.variants), out, {}, hulls)
    return dict(hulls.counts)


BUILD_DONE = "build.done"
BUILD_COUNTS = "build.counts.json"
BUILD_STARTED = "build.started"  # the background build's process id, written once
# "0": the session build as `svhdesc build` makes it (hulls and sampled results seeded from generated/), for a run
# without a slow test that uses it (the fast set: its tests read the outputs, and the slow guard in
# tests/compiler/pipeline/test_check.py, which every full run holds, proves generated/ is what the sources make).
FRESH_BUILD = "SVHDESC_TEST_FRESH_BUILD"


def start_build(run: Path, fresh: bool = True) -> None:
    """``built()`` in a background process, once per run: it takes the lock first, so a test that needs the build
    waits on it instead of starting its own."""
    if (run / BUILD_DONE).exists():
        return
    try:  # the first process here starts it; xdist's other workers find the file
        descriptor = os.open(run / BUILD_STARTED, os.O_WRONLY | os.O_CREAT | os.O_EXCL)
    except FileExistsError:
        return
    with open(run / "build.started.log", "wb") as log:
        process = subprocess.Popen(
            [sys.executable, "-c", "from tests.support import built; built()"],
            cwd=REPO,
            env={**os.environ, FRESH_BUILD: "1" if fresh else "0"},
            stdout=log,
            stderr=subprocess.STDOUT,
            start_new_session=True,
        )
    os.write(descriptor, str(process.pid).encode())
    os.close(descriptor)


def stop_build(run: Path) -> None:
    """A run that ends before its background build (a test selection, an interrupt) takes it down."""
    if (run / BUILD_DONE).exists():  # it has finished, or is about to: its id may soon be another's
        return
    try:
        os.killpg(int((run / BUILD_STARTED).read_text()), signal.SIGKILL)
    except (OSError, ValueError):  # none started, or it has ended
        pass


def compiled_variant(config: Path, cache: Path) -> tuple[Any, Any]:
    """The config's one variant compiled in this process as ``svhdesc build`` compiles it (hull cache ``cache``,
    seeded from generated/, nothing from an output folder), and the hull source (its ``counts``)."""
    from svhdesc.compiler.decompose import HullCache
    from svhdesc.compiler.decompose.source import HullSource
    from svhdesc.compiler.pipeline.steps import compile_variants
    from svhdesc.compiler.pipeline.timings import Timings

    hulls = HullSource(HullCache(cache))
    hulls.seed_from_outputs(sorted(p for p in (REPO / "generated").iterdir() if p.is_dir()))
    (compiled,) = compile_variants(load_config(config), [], {}, hulls, Timings())
    return compiled, hulls


def exported(config: Path, *names: str, into: Path | None = None) -> dict[str, bytes]:
    """The outputs ``names`` (registry names, "{robot}.urdf", "{robot}.xml") of the config's one variant, compiled in
    this process by the build's own pipeline and exporters, hulls seeded from generated/ as a build seeds them: the
    bytes ``svhdesc build --config CONFIG`` writes to those files. For the tests of what a setting does to the URDF
    and the MJCF: the outputs a build samples in MuJoCo (SRDF, batch model; about 12 s for each new model) are not
    made. ``into``: also written there as a build writes them, with the assets (``into``/assets/)."""
    from svhdesc.compiler.decompose.source import default_cache_dir
    from svhdesc.compiler.export.registry import OUTPUTS, Built
    from svhdesc.compiler.pipeline.freshness import svhdesc_version

    compiled, _ = compiled_variant(config, default_cache_dir())
    built = Built(compiled.robot, compiled.assets, config.parent, svhdesc_version())
    exporters = {output.name: output.export for output in OUTPUTS}
    files = {name.format(robot=compiled.robot.name): exporters[name](built) for name in names}
    if into is not None:
        for name, data in [*((f"assets/{k}", v) for k, v in compiled.assets.files.items()), *files.items()]:
            (into / name).parent.mkdir(parents=True, exist_ok=True)
            (into / name).write_bytes(data)
    return files


def model_files(variant: str) -> tuple[Path, Path]:
    directory = built() / variant
    return directory / f"{variant}.urdf", directory / f"{variant}.xml"


WHEELED_URDF = """<?xml version="1.0"?>
<robot name="wheeled">
  <link name="base"/>
  <link name="wheel_link">
    <inertial><mass value="1.0"/><inertia ixx="0.01" iyy="0.01" izz="0.02" ixy="0" ixz="0" iyz="0"/></inertial>
    <visual><geometry><cylinder radius="0.1" length="0.04"/></geometry></visual>
  </link>
  <link name="arm_link">
    <inertial><origin xyz="0 0 0.1"/><mass value="0.5"/>
      <inertia ixx="0.002" iyy="0.002" izz="0.0002" ixy="0" ixz="0" iyz="0"/></inertial>
    <visual><origin xyz="0 0 0.1"/><geometry><box size="0.04 0.04 0.2"/></geometry></visual>
  </link>
  <joint name="wheel" type="continuous">
    <parent link="base"/><child link="wheel_link"/><axis xyz="0 0 1"/><limit effort="5" velocity="3"/>
  </joint>
  <joint name="elbow" type="revolute">
    <parent link="wheel_link"/><child link="arm_link"/><origin xyz="0 0 0.05"/><axis xyz="0 1 0"/>
    <limit lower="-1.5" upper="1.5" effort="50" velocity="2"/>
  </joint>
</robot>
"""


@functools.cache
def wheeled() -> Path:
    """A robot with a wheel (a continuous joint) under an elbow, its config written by ``svhdesc init --joint
    wheel.servo=velocity`` and built with ``svhdesc build`` once per process (TIAGo's wheels, in small): the built
    variant's folder, ``<folder>/out/wheeled`` beside ``<folder>/wheeled.yaml``. Read it, do not change it."""
    run = os.environ.get("SVHDESC_TEST_RUN")
    folder = Path(tempfile.mkdtemp(prefix="wheeled-", dir=run if run and Path(run).is_dir() else None))
    source, config, out = folder / "wheeled.urdf", folder / "wheeled.yaml", folder / "out"
    source.write_text(WHEELED_URDF)
    for args in (
        ("init", str(source), "--out", str(config), "--joint", "wheel.servo=velocity"),
        ("build", "--config", str(config), "--out", str(out)),
    ):
        result = run_cli(*args, in_process=True)
        assert result.returncode == 0, result.stderr
    return out / "wheeled"


def pytest_in_venv(python: Path, files: list[str], basetemp: Path, env: dict[str, str] | None = None) -> None:
    """Run ``files`` with pytest in another venv's ``python`` (one process, no xdist): they must all pass there,
    none skipped (a venv missing what they import would otherwise pass here by skipping there)."""
    import re

    result = subprocess.run(
        [str(python), "-m", "pytest", "-q", "-n", "0", "-p", "no:cacheprovider", "--basetemp", str(basetemp), *files],
        cwd=REPO,
        env={**os.environ, **(env or {})},
        capture_output=True,
        text=True,
        timeout=900,
        check=False,
    )
    summary = result.stdout.strip().splitlines()[-1] if result.stdout.strip() else result.stderr
    assert result.returncode == 0, result.stdout[-3000:] + result.stderr[-2000:]
    assert re.search(r"\d+ passed", summary) and "skipped" not in summary, summary
