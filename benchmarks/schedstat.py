"""Each thread's time on a core and its wait for one, from Linux's /proc/<pid>/task/*/schedstat. No dependencies:
the ROS 2 benchmark's subscriber (in .venv-ros2) reads the node's threads with it too."""

from __future__ import annotations

from pathlib import Path


def thread_cpu(pid: int) -> dict[int, tuple[float, float]]:
    """Seconds each thread of process ``pid`` has run on a core and waited runnable for one (/proc schedstat)."""
    used = {}
    for task in Path(f"/proc/{pid}/task").iterdir():
        try:
            run, waited, _ = (task / "schedstat").read_text().split()
        except (OSError, ValueError):  # the thread ended meanwhile
            continue
        used[int(task.name)] = (int(run) / 1e9, int(waited) / 1e9)
    return used
