"""Decompositions in parallel worker processes that die with the build."""

from __future__ import annotations

import concurrent.futures
import math
import multiprocessing
import os
import resource
import sys
from collections import Counter
from collections.abc import Callable
from dataclasses import dataclass

import trimesh

from svhdesc.compiler.decompose.cache import HullCache, _entry_meta
from svhdesc.compiler.decompose.coacd_run import _decompose_stl
from svhdesc.compiler.decompose.keys import _key_from_stl
from svhdesc.compiler.decompose.params import DecompParams
from svhdesc.core.source.meshes import mesh_from_stl, stl_bytes
from svhdesc.errors import SvhdescError

# --------------------------------------------------------------------------- limits


@dataclass(frozen=True)
class Limits:
    """What one CoACD worker may use: CPU seconds for each mesh (the kernel stops it past them, SIGXCPU) and address
    space (past it, an allocation fails). CoACD's own defaults took 135 s on the SVH palm; the presets take < 10 s."""

    seconds: int = 600
    memory: int = 4 << 30  # bytes

    def said(self) -> str:
        return f"{self.seconds} s of CPU a mesh, {self.memory / 2**30:g} GiB of memory a worker"


LIMITS = Limits()

# --------------------------------------------------------------------------- parallel


def _init_worker(parent: int = 0, memory: int = 0) -> None:
    # One OpenMP thread per worker: the pool already fills the cores, and oversubscribing them
    # only slows every job.  Works because the worker imports CoACD lazily, after this.
    os.environ["OMP_NUM_THREADS"] = "1"
    die_with_parent(parent)
    if memory:
        resource.setrlimit(resource.RLIMIT_AS, (memory, memory))


def _cpu_budget(seconds: int) -> None:
    """Let this worker use ``seconds`` more of CPU from now: the next job's share (RLIMIT_CPU counts a process's
    whole life; the kernel sends SIGXCPU past the soft limit, which ends the worker)."""
    usage = resource.getrusage(resource.RUSAGE_SELF)
    used = math.ceil(usage.ru_utime + usage.ru_stime)
    hard = resource.getrlimit(resource.RLIMIT_CPU)[1]
    soft = used + seconds if hard == resource.RLIM_INFINITY else min(used + seconds, hard)
    resource.setrlimit(resource.RLIMIT_CPU, (soft, hard))


PR_SET_PDEATHSIG = 1


def die_with_parent(parent: int) -> None:
    """Linux: the kernel sends SIGKILL to this process when its parent dies (even by kill -9)."""
    if not sys.platform.startswith("linux"):
        return
    import ctypes
    import signal

    libc = ctypes.CDLL(None, use_errno=True)
    libc.prctl(PR_SET_PDEATHSIG, int(signal.SIGKILL), 0, 0, 0)
    if parent and os.getppid() != parent:  # the parent died before prctl took effect
        os._exit(1)


class _Progress:
    """A one-line progress bar on stderr (the caller decides whether stderr is a terminal)."""

    def __init__(self, total: int, enabled: bool, width: int = 30) -> None:
        self.total, self.enabled, self.width, self.done = total, enabled, width, 0

    def step(self, label: str) -> None:
        self.done += 1
        if not self.enabled or self.total == 0:
            return
        filled = self.width * self.done // self.total
        bar = "#" * filled + "-" * (self.width - filled)
        sys.stderr.write(f"\rdecompose [{bar}] {self.done}/{self.total} {label[:40]:<40}")
        if self.done == self.total:
            sys.stderr.write("\n")
        sys.stderr.flush()


Pending = dict[str, tuple[bytes, DecompParams, list[str]]]  # key -> (stl, params, job names)
Results = dict[str, tuple[list[trimesh.Trimesh], bool]]  # job name -> (hulls, cache hit)


def parallel_decompose(
    jobs: list[tuple[str, trimesh.Trimesh, DecompParams]],
    cache: HullCache | None,
    n_jobs: int,
    force: bool = False,
    progress: bool = False,
    stats: Counter[str] | None = None,
    limits: Limits = LIMITS,
) -> Results:
    """Decompose many meshes: hits come from the cache, misses run in ``n_jobs`` processes.

    Returns ``{name: (hulls, cache_hit)}`` in job order.  Results do not depend on ``n_jobs``
    (each is a function of its key alone); jobs with equal keys are decomposed once.
    ``n_jobs <= 0`` means one process per CPU.  CoACD runs in worker processes only, each under
    ``limits`` (a mesh past them: one SvhdescError naming them and the meshes, nothing hangs).  Workers
    are spawned, so a calling script needs the usual ``if __name__ == "__main__":`` guard.
    ``stats`` (the caller's counter) gets ``decomposed`` += 1 for every CoACD run.
    """
    stats = stats if stats is not None else Counter()
    names = [name for name, _, _ in jobs]
    if len(set(names)) != len(names):
        dupes = sorted({n for n in names if names.count(n) > 1})
        raise ValueError(f"duplicate job names: {', '.join(dupes)}")
    results: Results = {}
    bar = _Progress(len(jobs), progress)
    pending = _pending(jobs, None if force else cache, results, bar)

    def finish(key: str, blobs: list[bytes]) -> None:
        _, params, job_names = pending[key]
        if cache is not None:
            cache.store(key, blobs, _entry_meta(params))
        for job_name in job_names:
            results[job_name] = ([mesh_from_stl(b) for b in blobs], False)
            bar.step(job_name)

    workers = min(n_jobs if n_jobs > 0 else (os.cpu_count() or 1), len(pending))
    if pending:  # in workers even for one mesh: only there can its time and memory be bounded
        stats["decomposed"] += len(pending)  # all submitted at once
        _run_in_pool(pending, workers, finish, limits)
    return {name: results[name] for name in names}


def _pending(
    jobs: list[tuple[str, trimesh.Trimesh, DecompParams]], cache: HullCache | None, results: Results, bar: _Progress
) -> Pending:
    """The jobs to run, one per key; cache hits go straight into ``results``."""
    pending: Pending = {}
    for name, mesh, params in jobs:
        stl = stl_bytes(mesh)
        key = _key_from_stl(stl, params)
        if key in pending:
            pending[key][2].append(name)
            continue
        hit = None if cache is None else cache.hulls_for(key, mesh)
        if hit is not None:
            results[name] = (hit, True)
            bar.step(f"{name} (cached)")
        else:
            pending[key] = (stl, params, [name])
    return pending


def _run_in_pool(
    pending: Pending, workers: int, finish: Callable[[str, list[bytes]], None], limits: Limits = LIMITS
) -> None:
    # spawn, not fork: CoACD's OpenMP/TBB runtimes are not fork-safe once initialised.
    ctx = multiprocessing.get_context("spawn")
    with concurrent.futures.ProcessPoolExecutor(
        max(workers, 1), mp_context=ctx, initializer=_init_worker, initargs=(os.getpid(), limits.memory)
    ) as pool:
        futures = {
            pool.submit(_run_job, names[0], stl, params, limits): key for key, (stl, params, names) in pending.items()
        }
        try:
            for fut in concurrent.futures.as_completed(futures):
                finish(futures[fut], fut.result())
        except concurrent.futures.process.BrokenProcessPool:
            left = sorted(pending[futures[f]][2][0] for f in futures if not f.done() or f.exception() is not None)
            raise SvhdescError(
                f"convex decomposition of {', '.join(map(repr, left))}: a CoACD worker was stopped past its limits "
                f"({limits.said()})"
            ) from None
        except BaseException:
            for fut in futures:
                fut.cancel()
            raise


def _run_job(name: str, stl: bytes, params: DecompParams, limits: Limits = LIMITS) -> list[bytes]:
    _cpu_budget(limits.seconds)
    try:
        return _decompose_stl(stl, params)
    except MemoryError:
        raise SvhdescError(
            f"convex decomposition of {name!r}: out of memory under its limit ({limits.said()})"
        ) from None
    except Exception as exc:
        raise RuntimeError(f"convex decomposition of {name!r} failed: {exc}") from exc
