"""Publishing off the simulation thread, for both transports' nodes.

The simulation thread reads the state and collects (target, message) pairs; a second thread builds and sends the
messages while the next chunk of physics runs without the GIL (``mj_step`` releases it). Message stamps are
simulated time, so when a message leaves does not change what it says.
"""

from __future__ import annotations

import threading
import time
from collections import deque
from collections.abc import Callable, Iterable
from typing import Any

# wall s between two handovers to the publishing thread: waking it is a system call (tens of microseconds on the
# project's machine) and as fast as possible there are thousands of control updates a wall second; at real-time
# pace the updates are further apart than this, so nothing waits
HANDOVER = 0.002

Item = tuple[Any, Any]  # (a publisher, or any callable taking one message; the message)


class Outbox:
    """Collects what the simulation thread publishes and sends it from its own thread. When ``limit`` batches
    wait, the simulation waits too, so what subscribers see lags the physics by a few control periods at most,
    even when running as fast as possible."""

    def __init__(self, limit: int = 4, handover: float = HANDOVER) -> None:
        self._pending: list[Item] = []
        self._handed = 0.0  # perf_counter of the last handover
        self._handover = handover
        self._batches: deque = deque()
        self._limit = limit
        self._ready = threading.Condition()
        self._closed = False
        self._thread = threading.Thread(target=self._run, name="svhdesc-outbox", daemon=True)
        self._thread.start()

    def add(self, target: Any, message: Any) -> None:
        """Collect one message (simulation thread)."""
        self._pending.append((target, message))

    def extend(self, items: Iterable[Item]) -> None:
        self._pending.extend(items)

    def flush(self, force: bool = False) -> None:
        """Hand what was collected to the publishing thread, if HANDOVER has passed since the last time (or
        ``force``)."""
        now = time.perf_counter()
        if self._pending and (force or now - self._handed >= self._handover):
            batch, self._pending = self._pending, []
            self.send(batch)
            self._handed = now

    def send(self, batch: list[Item]) -> None:
        """Queue ``batch`` for the publishing thread at once."""
        with self._ready:
            while len(self._batches) >= self._limit and not self._closed:
                self._ready.wait(0.5)
            self._batches.append(batch)
            self._ready.notify_all()

    def _run(self) -> None:
        while True:
            with self._ready:
                while not self._batches and not self._closed:
                    self._ready.wait()
                if self._closed and not self._batches:
                    return
                batch = self._batches.popleft()
                self._ready.notify_all()
            # No time.sleep(0) between messages (about 20 us of CPU each here): every send to a subscriber is a
            # system call that releases the GIL, so the simulation thread, back from a chunk, takes it there.
            for target, message in batch:
                send: Callable[[Any], Any] = target.publish if hasattr(target, "publish") else target
                try:
                    send(message)
                except Exception:  # noqa: BLE001 - at shutdown the middleware refuses; the thread must live on
                    pass

    def close(self) -> None:
        """Send what is left, then stop the thread."""
        self.flush(force=True)
        with self._ready:
            self._closed = True
            self._ready.notify_all()
        self._thread.join(5.0)
