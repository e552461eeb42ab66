"""What the ROS 2 node tests share: the ROS 2 venv's Python, the independent client, the environment of a private
network namespace."""

from __future__ import annotations

import os
import subprocess
from pathlib import Path

from tests.netns import private_namespace

ROOT = Path(__file__).resolve().parents[2]
CLIENT = Path(__file__).with_name("client.py")
PYTHON = Path(os.environ.get("SVHDESC_ROS2_PYTHON", ROOT / ".venv-ros2" / "bin" / "python"))


def why_not() -> str | None:
    """Why the ROS 2 node tests cannot run here (None when they can)."""
    if not PYTHON.is_file():
        return f"no ROS 2 Python at {PYTHON} (bash tools/install.sh ros2, or set SVHDESC_ROS2_PYTHON)"
    namespace = private_namespace()
    if isinstance(namespace, str):
        return namespace
    imports = subprocess.run(
        [
            str(PYTHON),
            "-c",
            "import rclpy, control_msgs.action, controller_manager_msgs.srv, tf2_msgs.msg, rosbags, mcap_ros2",
        ],
        capture_output=True,
        text=True,
        timeout=60,
        check=False,
    )
    if imports.returncode != 0:
        return f"{PYTHON} lacks the ros2 extra: {imports.stderr.strip().splitlines()[-1:]}"
    return None


def private_env(work: Path) -> dict[str, str]:
    """The environment of a node or client in the private namespace: this checkout first on the path, DDS discovery
    on localhost only, ROS logs under ``work``."""
    env = {
        **os.environ,
        "PYTHONPATH": str(ROOT),  # the checkout under test
        "ROS_AUTOMATIC_DISCOVERY_RANGE": "LOCALHOST",
        "ROS_LOG_DIR": str(work / "roslog"),
    }
    env.pop("ROS_DOMAIN_ID", None)
    return env
