"""`svhdesc plan --execute`: plans sent to a running `svhdesc sim --ros` through the action servers that
moveit_controllers.yaml names, as MoveIt would; the tracking error comes back."""

from __future__ import annotations

import json
import subprocess
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from svhdesc.ros1.system import ros_available
from tests.rosmaster import master, stop, svhdesc_executable, wait_for
from tests.support import run_cli

pytestmark = [
    pytest.mark.skipif(not ros_available(), reason="Debian's python3-rospy is not installed"),
    pytest.mark.slow,
]

VARIANT = "ur5_svh_right"


@pytest.fixture(scope="module")
def sim(tmp_path_factory: pytest.TempPathFactory) -> Iterator[dict[str, Any]]:
    from svhdesc.ros1.system import import_ros

    import_ros()
    import rosgraph

    home = tmp_path_factory.mktemp("roshome")
    with master(home):  # this process stays off ROS (rospy binds one master per process): the CLI runs it
        rosgraph.Master("/svhdesc_test_plan").setParam("/use_sim_time", True)
        node = subprocess.Popen(
            [svhdesc_executable(), "sim", VARIANT, "--ros", "--as-fast"],
            stdout=(home / "node.out").open("w"),
            stderr=subprocess.STDOUT,
        )
        try:
            wait_for(
                lambda: any("/joint_states" == t for t, _ in rosgraph.Master("/t").getPublishedTopics("")),
                60,
                "/joint_states",
            )
            yield {"home": home, "node": node}
        finally:
            stop(node)


def _plan(tmp: Path, *args: str) -> tuple[Any, dict]:
    out = tmp / "plan.json"
    result = run_cli("plan", VARIANT, *args, "--execute", "--json", str(out))
    return result, json.loads(out.read_text()) if out.exists() else {}


def test_execute_home_to_test_and_back(sim: dict[str, Any], tmp_path: Path) -> None:
    for start, goal, group in (
        ("home", "test", "manipulator"),
        ("test", "home", "manipulator"),
        ("home", "test", "hand"),
    ):
        result, document = _plan(tmp_path, "--group", group, "--from", start, "--to", goal)
        assert result.returncode == 0, result.stderr
        execution = document["execution"]
        assert execution["success"], execution
        controller = "scaled_pos_joint_traj_controller" if group == "manipulator" else "right_hand_controller"
        assert execution["results"][controller]["error_code"] == 0
        assert 0 < execution["max_tracking_error"] < 0.05, execution  # rad, read from /<controller>/state
        assert execution["final_error"] < 0.01, execution
        assert "tracking error" in result.stdout
    assert sim["node"].poll() is None


def test_execute_refuses_a_plan_from_elsewhere(sim: dict[str, Any], tmp_path: Path) -> None:
    """The hand is at 'test' now (previous test): a plan that starts at the hand's home is refused."""
    result, _ = _plan(tmp_path, "--group", "hand", "--from", "home", "--to", "test")
    assert result.returncode == 2 and "not at the plan's start" in result.stderr, result.stderr
