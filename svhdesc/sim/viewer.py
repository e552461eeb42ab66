"""MuJoCo's passive viewer beside a running simulation, when a display exists."""

from __future__ import annotations

import os
import threading
import time
from typing import Any

from svhdesc.errors import SvhdescError


def has_display() -> bool:
    return bool(os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY"))


class Viewer:
    """Syncs the passive viewer at most ``fps`` times per wall-clock second."""

    def __init__(self, model: Any, data: Any, fps: float = 60.0) -> None:
        if not has_display():
            raise SvhdescError("--viewer needs a display (DISPLAY or WAYLAND_DISPLAY is not set)")
        import mujoco.viewer

        before = set(threading.enumerate())
        self._handle = mujoco.viewer.launch_passive(model, data)
        self._threads = set(threading.enumerate()) - before  # the viewer's own (daemon) thread
        self._period = 1.0 / fps
        self._last = 0.0

    @property
    def running(self) -> bool:
        return self._handle.is_running()

    def sync(self) -> None:
        now = time.perf_counter()
        if now - self._last >= self._period:
            self._handle.sync()
            self._last = now

    def close(self) -> None:
        # Join the viewer thread: exiting while it still tears its window down can crash.
        self._handle.close()
        for thread in self._threads:
            thread.join(5.0)
