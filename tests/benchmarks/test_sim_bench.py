"""benchmarks/sim_bench.py reads each thread's time on a core and its wait for one from /proc schedstat.

Seeded fault: the two fields swapped -> the busy thread's time on a core barely grows and the test fails.
"""

from __future__ import annotations

import importlib.util
import os
import sys
import threading
import time

import pytest

from tests.support import REPO


def test_thread_cpu_counts_a_busy_threads_time_on_a_core(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.syspath_prepend(str(REPO / "benchmarks"))  # its own imports (results, tcpros_sink)
    spec = importlib.util.spec_from_file_location("sim_bench", REPO / "benchmarks" / "sim_bench.py")
    bench = importlib.util.module_from_spec(spec)
    sys.modules.setdefault("sim_bench", bench)  # its dataclasses look their module up there
    spec.loader.exec_module(bench)
    me = threading.get_native_id()
    before = bench.thread_cpu(os.getpid())[me]
    start = time.thread_time()
    while time.thread_time() - start < 0.3:  # 0.3 s of this thread's CPU, however loaded the machine
        pass
    after = bench.thread_cpu(os.getpid())[me]
    assert after[0] - before[0] >= 0.25, (before, after)
    assert after[1] >= before[1]  # the wait for a core only grows
