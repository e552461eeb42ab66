"""svhdesc/control/outbox.py: what the simulation thread collects reaches its targets, in order, from the Outbox's
own thread; a target that raises does not stop it. Seeded faults: close() without its final flush (only the first
handover arrived: [0]); the per-item try removed (the thread died at the bad target, the later items never came)."""

from __future__ import annotations

import threading
import time

from svhdesc.control.outbox import Outbox


def test_everything_collected_arrives_in_order_by_close() -> None:
    sent: list[int] = []
    box = Outbox(handover=60.0)  # one handover by time (the first), the rest at close
    for i in range(100):
        box.add(sent.append, i)
        box.flush()
    box.close()
    assert sent == list(range(100))


def test_items_are_sent_from_the_outbox_thread_after_the_handover_time() -> None:
    threads: list[str] = []
    box = Outbox(handover=0.0)
    box.extend([(lambda _: threads.append(threading.current_thread().name), None)] * 3)
    box.flush()
    deadline = time.monotonic() + 10.0
    while len(threads) < 3 and time.monotonic() < deadline:
        time.sleep(0.01)
    box.close()
    assert threads == ["svhdesc-outbox"] * 3


def test_a_target_that_raises_does_not_stop_the_thread() -> None:
    sent: list[int] = []

    def bad(_: int) -> None:
        raise RuntimeError("the middleware refused")

    box = Outbox(handover=0.0)
    box.extend([(sent.append, 1), (bad, 2), (sent.append, 3)])
    box.flush()
    box.add(sent.append, 4)
    box.close()
    assert sent == [1, 3, 4]
