"""A real ROS 1 master on 127.0.0.1 (random free port) for the tests, and helpers around it."""

from __future__ import annotations

import os
import signal
import socket
import subprocess
import sys
import threading
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from functools import cache
from pathlib import Path
from typing import Any

ADDRESS = "127.0.0.1"


def free_port() -> int:
    with socket.socket() as s:
        s.bind((ADDRESS, 0))
        return s.getsockname()[1]


def ros_environment(port: int, home: Path) -> dict[str, str]:
    """Everything bound to 127.0.0.1; logs under ``home``."""
    return {
        "ROS_MASTER_URI": f"http://{ADDRESS}:{port}",
        "ROS_IP": ADDRESS,
        "ROS_HOSTNAME": ADDRESS,
        "ROS_HOME": str(home),
        "ROS_LOG_DIR": str(home / "log"),
    }


def wait_for(condition: Callable[[], Any], timeout: float, what: str, period: float = 0.05) -> Any:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        value = condition()
        if value:
            return value
        time.sleep(period)
    raise AssertionError(f"timed out after {timeout} s waiting for {what}")


@contextmanager
def master(home: Path) -> Iterator[dict[str, str]]:
    """rosmaster on a free port; the environment variables that reach it. Sets them in this process
    too (rospy reads them once, at init_node)."""
    port = free_port()
    env = ros_environment(port, home)
    os.environ.update(env)
    process = subprocess.Popen(
        ["rosmaster", "--core", "-p", str(port), "-w", "1"],
        env={**os.environ, **env},
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    try:
        import rosgraph

        wait_for(lambda: rosgraph.Master("/svhdesc_test").is_online(), 20, "rosmaster")
        yield env
    finally:
        stop(process)


def stop(process: subprocess.Popen) -> None:
    if process.poll() is None:
        process.send_signal(signal.SIGINT)
        try:
            process.wait(15)
        except subprocess.TimeoutExpired:
            process.kill()
            process.wait()


@contextmanager
def shut_down_if_it_dies(process: subprocess.Popen, rospy: Any) -> Iterator[None]:
    """With sim time, a dead node stops the clock, and actionlib's sim-time timeouts never end: when ``process``
    exits, rospy is shut down, which ends every wait (they return False, the test fails instead of hanging)."""
    done = threading.Event()

    def watch() -> None:
        while not done.wait(0.5):
            if process.poll() is not None:
                rospy.signal_shutdown(f"the node under test exited ({process.returncode})")
                return

    thread = threading.Thread(target=watch, daemon=True)
    thread.start()
    try:
        yield
    finally:
        done.set()
        thread.join()


def svhdesc_executable() -> str:
    return str(Path(sys.executable).with_name("svhdesc"))


def simple_action_client(name: str, action: Any) -> Any:
    """actionlib's SimpleActionClient without its race: an answer that arrives before ``send_goal`` has stored the
    goal's handle (the sending thread descheduled, as on a loaded machine) is dropped as "a goal handle that we're
    not tracking", and ``wait_for_result`` never returns. Here such an answer waits until ``send_goal`` is done."""
    return _race_free_client()(name, action)


@cache
def _race_free_client() -> type:
    import actionlib

    class Client(actionlib.SimpleActionClient):
        def __init__(self, *args: Any, **kwargs: Any) -> None:
            self._sending = threading.RLock()  # before the base class subscribes
            super().__init__(*args, **kwargs)

        def send_goal(self, *args: Any, **kwargs: Any) -> None:
            with self._sending:
                super().send_goal(*args, **kwargs)

        def _handle_transition(self, gh: Any) -> None:
            with self._sending:
                super()._handle_transition(gh)

        def _handle_feedback(self, gh: Any, feedback: Any) -> None:
            with self._sending:
                super()._handle_feedback(gh, feedback)

    return Client
