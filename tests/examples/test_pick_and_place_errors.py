"""examples/pick_and_place.py without what it needs: one ``error:`` line naming what to start, exit 2, no traceback.

Seeded fault: the example's ``except SvhdescError`` removed (the traceback of ros_node's error reaches the user:
both tests fail); the check for the simulation's topic removed (rospy waits 10 s for /tracked/can and raises
ROSException: the second fails).
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from svhdesc.ros1.system import ros_available
from tests.rosmaster import ADDRESS, free_port, master
from tests.support import REPO

pytestmark = pytest.mark.skipif(not ros_available(), reason="Debian's python3-rospy is not installed")

EXAMPLE = REPO / "examples" / "pick_and_place.py"
START = "svhdesc sim ur5_svh_right --ros --scene examples/pick_and_place.yaml --track can"


def run_example(env: dict[str, str]) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, str(EXAMPLE)], capture_output=True, text=True, timeout=120, env={**os.environ, **env}
    )


def test_no_master_says_to_start_roscore_and_the_simulation(tmp_path: Path) -> None:
    uri = f"http://{ADDRESS}:{free_port()}"  # nothing listens there
    result = run_example({"ROS_MASTER_URI": uri, "ROS_HOME": str(tmp_path), "ROS_LOG_DIR": str(tmp_path)})
    assert (result.returncode, result.stdout) == (2, "")
    assert result.stderr == f"error: no ROS master at {uri}: start roscore, then {START}\n"


@pytest.mark.ros
def test_a_master_without_the_simulation_says_to_start_it(tmp_path: Path) -> None:
    from svhdesc.ros1.system import import_ros

    import_ros()  # rosgraph, which master() asks whether the master is up
    saved = dict(os.environ)
    try:
        with master(tmp_path) as env:
            result = run_example(env)
    finally:  # master() sets the ROS variables in this process too
        os.environ.clear()
        os.environ.update(saved)
    assert (result.returncode, result.stdout) == (2, "")
    assert result.stderr == f"error: the simulation is not running (no /tracked/can topic): start {START}\n"
