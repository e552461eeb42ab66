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


class Latest:
    """A topic's newest message for the simulation thread, as a subscriber of queue size 1 keeps it (JTC's
    ``command``, a forward controller's ``commands``): a flood queues one work item at a time and each message
    replaces the one still waiting, so the queue (and the memory it holds) cannot grow with the flood's rate."""

    def __init__(self, queue: deque, handler: Callable[[Any], Any]) -> None:
        self._queue = queue
        self._handler = handler
        self._waiting: Any = None
        self._lock = threading.Lock()
        self.__name__ = getattr(handler, "__name__", "latest")  # drain's error lines name the handler

    def __call__(self, message: Any) -> None:
        """The transport's thread: keep ``message``, queue the work once."""
        with self._lock:
            queued = self._waiting is not None
            self._waiting = message
        if not queued:
            self._queue.append((self._run, None))

    def _run(self, _: Any) -> None:
        with self._lock:
            message, self._waiting = self._waiting, None
        if message is not None:
            self._handler(message)
