"""The private network namespace the ROS 2 tests and benchmarks/sim_bench_ros2.py run DDS in (loopback only)."""

from __future__ import annotations

import shutil
import subprocess


def private_namespace() -> list[str] | str:
    """The command that makes a private network namespace: ``unshare -n`` as root, else with a user namespace
    (``unshare -r -n``, where the kernel allows it); or why neither works."""
    if shutil.which("unshare") is None or shutil.which("ip") is None:
        return "unshare and ip (util-linux, iproute2) make the private network namespace"
    why = ""
    for command in (["unshare", "-n"], ["unshare", "-r", "-n"]):
        probe = subprocess.run([*command, "true"], capture_output=True, text=True, timeout=30, check=False)
        if probe.returncode == 0:
            return command
        why = probe.stderr.strip()
    return f"cannot make a network namespace: {why}"
