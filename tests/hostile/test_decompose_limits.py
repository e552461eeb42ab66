"""The build's convex decompositions (CoACD, in worker processes) bounded in time and memory (issue 48 item 5): a
mesh and settings that would run for minutes, or allocate gigabytes, stop the build with one error naming the
limits and the mesh; nothing hangs, and the machine keeps its memory. CoACD aborts its process on a failed
allocation (std::bad_alloc is not turned into a Python error) and on a remesh grid above 1,000: only a worker can
take that.

Seeded faults: no RLIMIT_CPU before a job (the slow case runs for minutes, past its 60 s bound: measured without a
limit, over 60 s); one mesh decomposed in the calling process, as before issue 48 (CoACD's abort on the greedy case
ends the test process). Not run as a fault: no RLIMIT_AS in the worker (the greedy remesh would take gigabytes of
this shared machine).
"""

from __future__ import annotations

import time

import pytest
import trimesh

from svhdesc.compiler.decompose import DecompParams
from svhdesc.compiler.decompose.params import DecompParamsError
from svhdesc.compiler.decompose.pool import Limits, parallel_decompose
from svhdesc.errors import SvhdescError

TORUS = trimesh.creation.torus(0.05, 0.02, major_sections=64, minor_sections=32)
# CoACD's widest search at a fine sampling: over a minute of CPU on this torus (measured: > 60 s)
SLOW = DecompParams(
    threshold=0.01,
    max_convex_hull=-1,
    preprocess_mode="off",
    resolution=300,
    mcts_nodes=20,
    mcts_iterations=150,
    mcts_max_depth=3,
)
# its manifold remesh on a 1000^3 grid: gigabytes (a std::bad_alloc under 2 GiB after 5 s of CPU)
GREEDY = DecompParams(threshold=0.01, max_convex_hull=-1, preprocess_mode="on", preprocess_resolution=1000)


def _refused(params: DecompParams, limits: Limits, bound: float) -> str:
    started = time.perf_counter()
    with pytest.raises(SvhdescError) as caught:
        parallel_decompose([("torus", TORUS, params)], None, n_jobs=1, limits=limits)
    assert time.perf_counter() - started < bound
    return str(caught.value)


def test_a_decomposition_past_its_time_is_stopped() -> None:
    said = _refused(SLOW, Limits(seconds=2), bound=60)
    assert "'torus'" in said and "2 s of CPU a mesh" in said, said


def test_a_decomposition_past_its_memory_is_stopped() -> None:
    said = _refused(GREEDY, Limits(memory=3 << 29), bound=90)
    assert "'torus'" in said and "1.5 GiB of memory" in said, said


def test_a_remesh_grid_coacd_would_abort_on_is_refused() -> None:
    with pytest.raises(DecompParamsError, match="'preprocess_resolution' must be <= 1000"):
        DecompParams(preprocess_resolution=1001)
