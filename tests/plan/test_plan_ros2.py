"""`svhdesc plan --execute --ros2`: plans sent to a running `svhdesc sim --ros2` through the action servers the
variant's ROS 2 moveit_controllers.yaml names (hand joints under SCHUNK's ROS 2 names), as MoveIt 2 would; the
tracking error comes back from each controller's controller_state. Node and planner run in the ROS 2 venv, in a
private network namespace with DDS discovery on localhost.

Seeded fault: svhdesc/plan/ros2.py sending the plan's own joint names (no ros2_joint_name) -> the hand's goal is
rejected (INVALID_JOINTS: its joints are Right_Hand_*) and the hand's execution fails."""

from __future__ import annotations

import importlib.util
import json
import shlex
import subprocess
from pathlib import Path
from typing import Any

import pytest

from tests.netns import private_namespace
from tests.ros2.support import PYTHON, private_env, why_not
from tests.support import run_cli

pytestmark = [pytest.mark.ros, pytest.mark.slow]

VARIANT = "ur5_svh_right"
RUNS = (  # (name, group, from, to): the ROS 1 test's sequence, then a plan from where the hand no longer is
    ("arm_out", "manipulator", "home", "test"),
    ("arm_back", "manipulator", "test", "home"),
    ("hand", "hand", "home", "test"),
    ("elsewhere", "hand", "home", "test"),
)


@pytest.fixture(scope="module")
def executed(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Any]:
    """One node, four `plan --execute --ros2` runs against it: each run's exit code, JSON and stderr."""
    why = why_not()
    if why:
        pytest.skip(why)
    work = tmp_path_factory.mktemp("plan-ros2")
    python = shlex.quote(str(PYTHON))
    plans = "\n".join(
        f"{python} -m svhdesc.cli plan {VARIANT} --group {group} --from {start} --to {goal} --execute --ros2 "
        f"--json {work}/{name}.json > {work}/{name}.out 2> {work}/{name}.err; echo {name} $? >> {work}/exits"
        for name, group, start, goal in RUNS
    )
    script = f"""
ip link set lo up
{python} -m svhdesc.cli sim {VARIANT} --ros2 --as-fast > {work}/node.log 2>&1 &
node=$!
{plans}
kill -INT $node
wait $node
echo node $? >> {work}/exits
"""
    namespace = private_namespace()
    assert isinstance(namespace, list)
    subprocess.run([*namespace, "sh", "-c", script], env=private_env(work), timeout=900, check=False)
    exits = dict(line.split() for line in (work / "exits").read_text().splitlines())

    def run(name: str) -> dict[str, Any]:
        document = work / f"{name}.json"
        return {
            "code": int(exits[name]),
            "plan": json.loads(document.read_text()) if document.exists() else {},
            "stdout": (work / f"{name}.out").read_text(),
            "stderr": (work / f"{name}.err").read_text(),
        }

    return {"runs": {name: run(name) for name, *_ in RUNS}, "node": exits.get("node"), "work": work}


@pytest.mark.parametrize(
    ("name", "controller"),
    [
        ("arm_out", "scaled_joint_trajectory_controller"),
        ("arm_back", "scaled_joint_trajectory_controller"),
        ("hand", "right_hand"),
    ],
)
def test_execute_over_ros2(executed: dict[str, Any], name: str, controller: str) -> None:
    run = executed["runs"][name]
    assert run["code"] == 0, run["stderr"][-3000:]
    execution = run["plan"]["execution"]
    assert execution["success"] and list(execution["results"]) == [controller], execution
    assert execution["results"][controller]["error_code"] == 0
    assert 0 < execution["max_tracking_error"] < 0.05, execution  # rad, from /<controller>/controller_state
    assert execution["final_error"] < 0.01, execution
    assert "tracking error" in run["stdout"]


def test_a_plan_from_elsewhere_is_refused_and_the_node_ran_on(executed: dict[str, Any]) -> None:
    """The hand is at 'test' now: a plan from the hand's home is refused, one error line, exit 2; the node ran until
    it was interrupted and stopped cleanly."""
    run = executed["runs"]["elsewhere"]
    lines = run["stderr"].strip().splitlines()
    assert run["code"] == 2 and len(lines) == 1 and "not at the plan's start" in lines[0], run["stderr"]
    assert executed["node"] == "0", (executed["work"] / "node.log").read_text()[-3000:]


def test_ros2_needs_execute_and_rclpy(tmp_path: Path) -> None:
    """--ros2 alone is refused before planning; from a Python without rclpy, one error line naming .venv-ros2."""
    result = run_cli("plan", VARIANT, "--group", "hand", "--from", "home", "--to", "test", "--ros2")
    assert result.returncode == 2 and result.stderr.strip() == (
        "error: --ros2 says where --execute sends the plan: give --execute too"
    ), result.stderr
    if importlib.util.find_spec("rclpy") is not None:
        return  # this Python has rclpy: the runs above are its test
    result = run_cli("plan", VARIANT, "--group", "hand", "--from", "home", "--to", "test", "--execute", "--ros2")
    lines = result.stderr.strip().splitlines()
    assert result.returncode == 2 and len(lines) == 1 and ".venv-ros2" in lines[0], result.stderr
