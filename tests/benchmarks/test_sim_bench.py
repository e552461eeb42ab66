"""benchmarks/sim_bench.py reads each thread's time on a core and its wait for one from /proc schedstat.

Seeded fault: the two fields swapped -> the busy thread's time on a core barely grows and the test fails.
"""

from __future__ import annotations

import os
import threading
import time

from tests.benchmarks.scripts import load


def test_thread_cpu_counts_a_busy_threads_time_on_a_core() -> None:
    bench = load("sim_bench")
    me = threading.get_native_id()
    before = bench.thread_cpu(os.getpid())[me]
    start = time.thread_time()
    while time.thread_time() - start < 0.3:  # 0.3 s of this thread's CPU, however loaded the machine
        pass
    after = bench.thread_cpu(os.getpid())[me]
    assert after[0] - before[0] >= 0.25, (before, after)
    assert after[1] >= before[1]  # the wait for a core only grows
