"""Importing rclpy (lazily: the ROS 2 Jazzy wheels live in their own venv, .venv-ros2)."""

from __future__ import annotations

import sys
from types import ModuleType
from typing import Any

from svhdesc.errors import SvhdescError

MISSING = (
    "--ros2 needs ROS 2 Jazzy's rclpy, control_msgs and tf2_msgs, which {python} cannot import ({why}): run it with "
    ".venv-ros2/bin/python -m svhdesc.cli (or .venv-ros2/bin/svhdesc), made by `bash tools/install.sh ros2`"
)


def import_rclpy() -> ModuleType:
    """rclpy, or an SvhdescError saying which venv has it (control_msgs too: it is built at install time)."""
    try:
        import control_msgs.action  # noqa: F401 - built by tools/build_ros2_interfaces.sh
        import controller_manager_msgs.srv  # noqa: F401
        import rclpy
        import tf2_msgs.msg  # noqa: F401 - built beside control_msgs
    except ImportError as exc:  # ModuleNotFoundError, or a wheel whose native library does not load
        raise SvhdescError(MISSING.format(python=sys.executable, why=exc)) from None
    return rclpy


def log_at(logger: Any, level: str, text: str) -> None:
    """Log ``text`` at ``level`` ('error', else a warning). One call line per severity: rclpy remembers each call
    site's severity and raises ("Logger severity cannot be changed between calls") when one line uses two."""
    if level == "error":
        logger.error(text)
    else:
        logger.warning(text)
