"""Work handed to the simulation thread: transports queue callables, the simulation thread runs them."""

from __future__ import annotations

import threading
from collections import deque
from collections.abc import Callable
from typing import Any


def on_sim_thread(queue: deque, work: Callable[[], Any], timeout: float = 10.0) -> Any:
    """Run ``work`` on the simulation thread (which drains ``queue``) and wait for its value."""
    done = threading.Event()
    box: list[Any] = []

    def run(_: Any) -> None:
        try:
            box.append(work())
        finally:
            done.set()

    queue.append((run, None))
    if not done.wait(timeout) or not box:
        return "the simulation did not answer"
    return box[0]
