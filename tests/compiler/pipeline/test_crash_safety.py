"""Faults during a build: SIGKILL inside the swap, two builds at once, dead parents, a broken cache."""

from __future__ import annotations

import hashlib
import json
import os
import random
import signal
import subprocess
import sys
import time
from collections.abc import Callable
from pathlib import Path

import pytest
import trimesh

from svhdesc.compiler.pipeline.outdir import NO_EXCHANGE_ENV, PAUSE_ENV, STAGING_PREFIX, recover
from tests.support import REPO, fails_cleanly, run_cli, snapshot


@pytest.fixture
def mini(project: Callable[..., Path]) -> Callable[..., Path]:
    """``mini(variants, collision)``: a copy of the mini robot with ``variants`` identical variants (so a swap has a
    first and a second)."""

    def copy(variants: int = 2, collision: str = "{mode: hull}") -> Path:
        root = project("mini")
        text = (root / "mini.yaml").read_text().replace("collision: {mode: hull}", f"collision: {collision}")
        extra = "".join(f"  mini_{i}:\n    xacro: mini.xacro\n" for i in range(1, variants))
        (root / "mini.yaml").write_text(text + extra)
        return root

    return copy


def start(root: Path, out: Path, *args: str, env: dict[str, str] | None = None) -> subprocess.Popen[str]:
    return subprocess.Popen(
        [sys.executable, "-m", "svhdesc.cli", "build", "--config", str(root / "mini.yaml"), "--out", str(out), *args],
        cwd=REPO,
        env={**os.environ, **(env or {})},
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )


def build(
    root: Path, out: Path, *args: str, env: dict[str, str] | None = None, own_process: bool = False
) -> subprocess.CompletedProcess[str]:
    """A build nobody kills: in this process (an interpreter start costs more than the mini robot's build), or in
    ``own_process`` where its warnings are counted (here another test's garbage may warn meanwhile)."""
    config = ("--config", str(root / "mini.yaml"), "--out", str(out))
    return run_cli("build", *config, *args, env=env, in_process=not own_process)


def complete(directory: Path) -> str:
    """The directory's kp (which build it is from), after checking it holds exactly its manifest's outputs."""
    manifest = json.loads((directory / "manifest.json").read_text())
    present = {p.relative_to(directory).as_posix() for p in directory.rglob("*") if p.is_file()}
    assert present == set(manifest["outputs"]) | {"manifest.json"}
    for name, digest in manifest["outputs"].items():
        assert hashlib.sha256((directory / name).read_bytes()).hexdigest() == digest, name
    mjcf = (directory / f"{directory.name}.xml").read_text()
    return mjcf.split('kp="', 1)[1].split('"', 1)[0]


def wait_for(process: subprocess.Popen[str], text: str) -> None:
    assert process.stderr is not None
    for line in process.stderr:
        if text in line:
            return
    raise AssertionError(f"build ended before {text!r} (exit {process.wait()})")


@pytest.mark.slow
def test_sigkill_inside_the_swap_leaves_whole_variants_and_the_next_build_cleans_up(
    tmp_path: Path, mini: Callable[..., Path]
) -> None:
    root, out = mini(), tmp_path / "out"
    assert build(root, out).returncode == 0
    assert {complete(out / "mini"), complete(out / "mini_1")} == {"1"}
    (root / "mini.yaml").write_text((root / "mini.yaml").read_text().replace("kp: 1.0", "kp: 2.0"))
    process = start(root, out, env={PAUSE_ENV: str(tmp_path / "never")})
    wait_for(process, "pausing")  # the first variant is swapped in, the second is not
    process.send_signal(signal.SIGKILL)
    process.wait()
    assert complete(out / "mini") == "2"  # new, whole
    assert complete(out / "mini_1") == "1"  # old, whole
    assert list(out.glob(f"{STAGING_PREFIX}*"))  # the killed build's leftovers ...
    result = build(root, out)
    assert result.returncode == 0, result.stderr
    assert not list(out.glob(f"{STAGING_PREFIX}*"))  # ... are gone after the next build
    assert sorted(p.name for p in out.iterdir()) == ["mini", "mini_1"]
    assert {complete(out / "mini"), complete(out / "mini_1")} == {"2"}


def test_recover_puts_back_a_variant_moved_aside_by_the_rename_fallback(tmp_path: Path) -> None:
    # Without renameat2 the swap is two renames; a kill between them leaves OUT/X missing.
    out = tmp_path / "out"
    retired = out / f"{STAGING_PREFIX}x" / ".old-hand"
    retired.mkdir(parents=True)
    (retired / "hand.xml").write_text("<mujoco/>")
    recover(out)
    assert (out / "hand" / "hand.xml").read_text() == "<mujoco/>"
    assert [p.name for p in out.iterdir()] == ["hand"]


@pytest.mark.slow
def test_concurrent_builds_into_one_out_serialise(tmp_path: Path, mini: Callable[..., Path]) -> None:
    root, out = mini(), tmp_path / "out"
    release = tmp_path / "release"
    first = start(root, out, env={PAUSE_ENV: str(release)})
    wait_for(first, "pausing")  # holds the lock
    second = start(root, out, "--force")
    wait_for(second, "waiting for another build")
    release.touch()
    assert first.wait(timeout=300) == 0
    assert second.wait(timeout=300) == 0
    assert sorted(p.name for p in out.iterdir()) == ["mini", "mini_1"]
    assert {complete(out / "mini"), complete(out / "mini_1")} == {"1"}


def _descendants(pid: int) -> set[int]:
    found, todo = set(), [pid]
    while todo:
        current = todo.pop()
        for task in Path(f"/proc/{current}/task").glob("*"):
            try:
                children = (task / "children").read_text().split()
            except OSError:
                continue
            for child in map(int, children):
                if child not in found:
                    found.add(child)
                    todo.append(child)
    return found


def _alive(pid: int) -> bool:
    try:
        state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except OSError:
        return False
    return state != "Z"


@pytest.mark.slow
@pytest.mark.skipif(not Path("/proc/self/task").is_dir(), reason="needs Linux /proc")
def test_decomposition_workers_die_with_a_killed_build(tmp_path: Path, mini: Callable[..., Path]) -> None:
    params = "{mode: decompose, params: {threshold: 0.02, max_convex_hull: -1, resolution: 4000}}"
    root, out = mini(variants=1, collision=params), tmp_path / "out"
    # A second, different collision mesh: two decompositions, so they run in a pool of two workers.
    trimesh.creation.icosphere(subdivisions=3, radius=0.02).export(root / "ball.stl")
    xacro = root / "mini.xacro"
    xacro.write_text(xacro.read_text().replace('<box size="0.04 0.04 0.02"/>', '<mesh filename="ball.stl"/>'))
    env = {"SVHDESC_CACHE": str(tmp_path / "cache")}
    process = start(root, out, "--rebuild-collisions", "-j", "2", env=env)
    workers: set[int] = set()
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline and process.poll() is None:
        workers = {p for p in _descendants(process.pid) if "spawn_main" in Path(f"/proc/{p}/cmdline").read_text()}
        if len(workers) >= 2:
            break
        time.sleep(0.05)
    assert workers, "no worker processes seen"
    time.sleep(0.5)  # past the workers' initializer
    process.send_signal(signal.SIGKILL)
    process.wait()
    time.sleep(5)
    assert not [p for p in workers if _alive(p)]


@pytest.mark.slow
def test_a_broken_cache_warns_once_and_the_build_goes_on(tmp_path: Path, mini: Callable[..., Path]) -> None:
    params = "{mode: decompose, params: {threshold: 0.1, max_convex_hull: 2, resolution: 500}}"
    root = mini(variants=1, collision=params)
    blocker = tmp_path / "cache-file"
    blocker.write_text("a file where the cache directory should be")
    result = build(root, tmp_path / "out", env={"SVHDESC_CACHE": str(blocker)}, own_process=True)
    assert result.returncode == 0, result.stderr
    warnings = [line for line in result.stderr.splitlines() if line.startswith("warning:")]
    assert len(warnings) == 1 and "building without caching" in warnings[0], result.stderr
    assert blocker.read_text().startswith("a file")
    reference = complete(tmp_path / "out" / "mini")

    # An entry that passes its checksums but does not parse as STL is rebuilt, not a crash.
    cache = tmp_path / "cache"
    assert build(root, tmp_path / "warm", env={"SVHDESC_CACHE": str(cache)}).returncode == 0
    [entry] = [p for p in cache.iterdir() if (p / "entry.json").is_file()]  # hull entries (not capacities/...)
    meta = json.loads((entry / "entry.json").read_text())
    garbage = b"not an stl"
    (entry / meta["files"][0]["name"]).write_bytes(garbage)
    meta["files"][0]["sha256"] = hashlib.sha256(garbage).hexdigest()
    (entry / "entry.json").write_text(json.dumps(meta))
    result = build(root, tmp_path / "again", env={"SVHDESC_CACHE": str(cache)})
    assert result.returncode == 0, result.stderr
    assert complete(tmp_path / "again" / "mini") == reference
    assert (entry / meta["files"][0]["name"]).read_bytes() != garbage  # rebuilt into the cache


@pytest.mark.parametrize("content", [b"[1, 2]", b'{"outputs": 5}', b"\xff\xfe\x00", b'{"decompositions": {"k": 7}}'])
def test_a_damaged_manifest_means_rebuild_not_crash(tmp_path: Path, content: bytes, mini: Callable[..., Path]) -> None:
    root, out = mini(variants=1), tmp_path / "out"
    assert build(root, out).returncode == 0
    good = (out / "mini" / "manifest.json").read_bytes()
    (out / "mini" / "manifest.json").write_bytes(content)
    result = build(root, out)
    assert result.returncode == 0 and "built" in result.stdout, result.stderr
    assert (out / "mini" / "manifest.json").read_bytes() == good


@pytest.mark.slow
def test_sigkill_at_random_moments_never_leaves_a_partial_variant(tmp_path: Path, mini: Callable[..., Path]) -> None:
    root, out = mini(), tmp_path / "out"
    assert build(root, out).returncode == 0
    rng = random.Random(8)
    kp = 1.0
    for _ in range(6):
        (root / "mini.yaml").write_text((root / "mini.yaml").read_text().replace(f"kp: {kp}", f"kp: {kp + 1}"))
        kp += 1
        process = start(root, out)
        time.sleep(rng.uniform(0.2, 2.0))
        process.send_signal(signal.SIGKILL)
        process.wait()
        for name in ("mini", "mini_1"):  # whole, and from one of the builds so far
            assert complete(out / name) in {f"{k:g}" for k in range(1, int(kp) + 1)}
    result = build(root, out)
    assert result.returncode == 0, result.stderr
    assert sorted(p.name for p in out.iterdir()) == ["mini", "mini_1"]
    assert {complete(out / "mini"), complete(out / "mini_1")} == {f"{kp:g}"}


@pytest.mark.slow
def test_a_full_cache_warns_once_and_the_build_goes_on(tmp_path: Path, mini: Callable[..., Path]) -> None:
    params = "{mode: decompose, params: {threshold: 0.1, max_convex_hull: 2, resolution: 500}}"
    root = mini(variants=1, collision=params)
    cache = tmp_path / "cache"
    cache.mkdir()
    if subprocess.run(["mount", "-t", "tmpfs", "-o", "size=4k", "tmpfs", str(cache)], capture_output=True).returncode:
        pytest.skip("cannot mount a tmpfs here (needs root)")
    try:
        (cache / "filler").write_bytes(b"x" * 4096)  # the cache's filesystem is now full
        result = build(root, tmp_path / "out", env={"SVHDESC_CACHE": str(cache)}, own_process=True)
    finally:
        subprocess.run(["umount", "-l", str(cache)], check=False)
    assert result.returncode == 0, result.stderr
    warnings = [line for line in result.stderr.splitlines() if line.startswith("warning:")]
    assert len(warnings) == 1 and "building without caching" in warnings[0], result.stderr
    complete(tmp_path / "out" / "mini")


NO_EXCHANGE = {NO_EXCHANGE_ENV: "1"}


def test_without_rename_exchange_a_replacing_build_is_refused_before_it_writes(
    tmp_path: Path, mini: Callable[..., Path], monkeypatch: pytest.MonkeyPatch
) -> None:
    """Where directories cannot be exchanged, two renames would leave OUT/<variant> missing between them: such a
    build is refused up front, naming the filesystem, with OUT untouched (seeded fault: require_exchange() not
    called, and the build reaches swap_in's own refusal only after writing its staging folder)."""
    root, out = mini(), tmp_path / "out"
    monkeypatch.setenv(NO_EXCHANGE_ENV, "1")
    assert build(root, out).returncode == 0  # new variants are renamed into place: atomic everywhere
    assert sorted(p.name for p in out.iterdir()) == ["mini", "mini_1"]
    before = snapshot(out)
    args = ("build", "--config", str(root / "mini.yaml"), "--out", str(out), "--force")
    fails_cleanly(out, *args, match="cannot exchange directories atomically")
    error = fails_cleanly(out, *args, match="filesystem '")
    assert str(out) in error and "mini" in error
    assert snapshot(out) == before  # no staging folder left, nothing swapped


@pytest.mark.slow
def test_sigkill_at_every_moment_of_a_build_without_rename_exchange(tmp_path: Path, mini: Callable[..., Path]) -> None:
    """Forced onto the no-exchange path, a build killed at any moment leaves each variant whole or absent (new
    variants, renamed in), and the next build finishes the job."""
    root = mini()
    for delay in (0.3, 0.8, 1.5, 2.5):
        out = tmp_path / f"out-{delay}"
        process = start(root, out, env=NO_EXCHANGE)
        time.sleep(delay)
        process.send_signal(signal.SIGKILL)
        process.wait()
        for name in ("mini", "mini_1"):
            if (out / name).exists():
                assert complete(out / name) == "1"
        result = build(root, out, env=NO_EXCHANGE, own_process=True)
        assert result.returncode == 0, result.stderr
        assert sorted(p.name for p in out.iterdir()) == ["mini", "mini_1"]


@pytest.mark.slow
def test_a_killed_build_s_staging_folder_goes_even_when_all_is_up_to_date(
    tmp_path: Path, mini: Callable[..., Path]
) -> None:
    """A build killed right after its last swap leaves its staging folder; the next build (up to date, so it
    builds nothing) and --check remove it (seeded fault: tidy() not called before the freshness shortcut)."""
    root, out = mini(), tmp_path / "out"
    assert build(root, out).returncode == 0
    for command in ((), ("--check",)):
        leftover = out / f"{STAGING_PREFIX}killed"
        (leftover / "mini").mkdir(parents=True)
        (leftover / "mini" / "big.stl").write_bytes(b"x" * 1000)
        result = build(root, out, *command)
        assert result.returncode == 0, result.stderr
        assert not leftover.exists(), command
        assert sorted(p.name for p in out.iterdir()) == ["mini", "mini_1"]
