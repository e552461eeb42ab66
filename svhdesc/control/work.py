"""Work handed to the simulation thread: transports queue callables, the simulation thread runs them."""

from __future__ import annotations

import threading
from collections import deque
from collections.abc import Callable
from typing import Any

# Queued callbacks (goals, cancels, commands, queries) worked per control update: a burst of 1000 goals
# then takes a few hundred updates, while the physics, /clock and /joint_states go on.
WORK_PER_UPDATE = 8


def drain(queue: deque, report: Callable[[str], Any], limit: int | None = WORK_PER_UPDATE) -> int:
    """Work the callbacks queued, at most ``limit`` of them (None: all); the number worked. A handler's exception
    is reported (``report``, one line naming the handler) and never stops the simulation thread."""
    done = 0
    while queue and (limit is None or done < limit):
        handler, argument = queue.popleft()
        done += 1
        try:
            handler(argument)
        except Exception as exc:  # noqa: BLE001 - one bad message must never stop the node
            report(f"{getattr(handler, '__name__', handler)}: {type(exc).__name__}: {exc}")
    return done


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
