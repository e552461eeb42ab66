"""Debian's ROS 1 Python packages, seen from the virtual environment.

The venv does not see /usr/lib/python3/dist-packages; it is appended (never prepended) to
sys.path so the venv's own packages (numpy, yaml, ...) keep precedence.
"""

from __future__ import annotations

import socket
import sys
import warnings
from types import ModuleType
from typing import Any

from svhdesc.errors import SvhdescError

DIST_PACKAGES = "/usr/lib/python3/dist-packages"
# Debian 12 packages the node needs (ros-core brings roscore and roslaunch).
APT_PACKAGES = (
    "ros-core",
    "python3-rospy",
    "python3-actionlib",
    "python3-actionlib-msgs",
    "python3-genpy",
    "python3-genmsg",
    "python3-std-msgs",
    "python3-sensor-msgs",
    "python3-geometry-msgs",
    "python3-trajectory-msgs",
    "python3-rosgraph-msgs",
    "ros-robot-state-publisher",
)


def ros_available() -> bool:
    from pathlib import Path

    return (Path(DIST_PACKAGES) / "rospy" / "__init__.py").is_file()


# s a synchronous send to one subscriber may block before rospy drops that subscriber's connection
STALLED_SUBSCRIBER_TIMEOUT = 1.0
# bytes of send buffer per subscriber (Linux doubles it): bounds what a stalled subscriber holds, and without it
# loopback autotuning grows the buffer to 4 MB, so a stall shows only after a minute at real-time pace
SEND_BUFFER = 64 * 1024


def synchronous_publisher(topic: str, kind: Any) -> Any:
    """A rospy publisher that serialises and sends in ``publish`` itself. rospy's queued ones hand every message
    to a thread per subscriber and then call time.sleep(0) (about 20 us of CPU a message on this project's
    machine): the node publishes from its own publishing thread instead (svhdesc/control/outbox.py).

    A subscriber that stops reading would block a synchronous send for ever once the socket's buffers are full,
    and the node with it: each subscriber's socket gets a bounded send buffer and a send timeout, and rospy closes a
    connection whose send failed (the subscriber may reconnect), so the node stalls STALLED_SUBSCRIBER_TIMEOUT at
    most."""
    rospy = import_ros()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # rospy warns that queue_size=None publishes synchronously
        publisher = rospy.Publisher(topic, kind, queue_size=None)
    time_out_stalled_subscribers(publisher)
    return publisher


def time_out_stalled_subscribers(publisher: Any, seconds: float = STALLED_SUBSCRIBER_TIMEOUT) -> None:
    """Every connection ``publisher`` accepts from now on sends through SEND_BUFFER with a timeout of ``seconds``."""
    impl = publisher.impl
    if getattr(impl, "_svhdesc_timeout", None) is not None:  # rospy shares one impl per topic
        return
    add = impl.add_connection

    def add_connection(connection: Any) -> Any:
        sock = getattr(connection, "socket", None)
        if sock is not None:
            sock.setsockopt(socket.SOL_SOCKET, socket.SO_SNDBUF, SEND_BUFFER)
            sock.settimeout(seconds)
        return add(connection)

    impl.add_connection = add_connection
    impl._svhdesc_timeout = seconds


def import_ros() -> ModuleType:
    """``rospy`` (with actionlib and the message packages importable), or a clear error."""
    if DIST_PACKAGES not in sys.path:
        sys.path.append(DIST_PACKAGES)
    try:
        import actionlib  # noqa: F401
        import actionlib_msgs.msg  # noqa: F401
        import genpy  # noqa: F401
        import geometry_msgs.msg  # noqa: F401
        import rosgraph_msgs.msg  # noqa: F401
        import rospy
        import sensor_msgs.msg  # noqa: F401
        import std_msgs.msg  # noqa: F401
        import trajectory_msgs.msg  # noqa: F401
    except ImportError as exc:
        raise SvhdescError(
            f"the ROS node needs Debian's ROS 1 Python packages ({exc}): apt-get install {' '.join(APT_PACKAGES)}"
        ) from None
    return rospy
