"""The ROS node under abuse: 1000 malformed or random goals (paced, then in one burst) and raw garbage on its
sockets, /command flooded at 1 kHz for 10 s, a client killed mid-goal, a subscriber that stops reading. After
each, the node still serves (a valid goal succeeds, /joint_states flows) and its resident memory grows by less than
16 MB over the module.

One node (svh_right, real-time pace) on its own master serves the module (about 40 s in all); each
check's client runs in its own process (tests/ros/abuse.py), as rospy binds one master per process.
"""

from __future__ import annotations

import json
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from svhdesc.ros1.system import ros_available
from tests.rosmaster import master, stop, svhdesc_executable, wait_for
from tests.support import TESTS

pytestmark = [
    pytest.mark.skipif(not ros_available(), reason="Debian's python3-rospy is not installed"),
    pytest.mark.slow,
]

VARIANT = "svh_right"
ABUSE = TESTS / "ros" / "abuse.py"
# 10 MB before the result queue grew from actionlib's 50 to 2000 (RESULT_QUEUE: a burst's answers are kept, not
# dropped); a 1000-goal burst now leaves up to its results in rospy's queue, and the node was seen at 10.1 MB.
# A leak still shows: the idle leak this guards against grew ~2.3 MB a minute, far more over the abuse above.
MEMORY_LIMIT_KB = 16 * 1024


def rss_kb(pid: int) -> int:
    for line in Path(f"/proc/{pid}/status").read_text().splitlines():
        if line.startswith("VmRSS:"):
            return int(line.split()[1])
    raise AssertionError(f"no VmRSS for {pid}")


def abuse(node: dict[str, Any], check: str) -> dict[str, Any]:
    result = subprocess.run([sys.executable, str(ABUSE), check], capture_output=True, text=True, timeout=360)
    assert result.returncode == 0, result.stdout[-2000:] + result.stderr[-4000:]
    assert node["process"].poll() is None, "the node died"
    return json.loads(result.stdout.strip().splitlines()[-1])


@pytest.fixture(scope="module")
def node(tmp_path_factory: pytest.TempPathFactory) -> Iterator[dict[str, Any]]:
    from svhdesc.ros1.system import import_ros

    import_ros()
    import rosgraph

    home = tmp_path_factory.mktemp("roshome")
    with master(home):
        process = subprocess.Popen(
            [svhdesc_executable(), "sim", VARIANT, "--ros", "--realtime"],
            stdout=(home / "node.out").open("w"),
            stderr=subprocess.STDOUT,
        )
        try:
            topics = lambda: [t for t, _ in rosgraph.Master("/svhdesc_test").getPublishedTopics("")]  # noqa: E731
            wait_for(lambda: "/joint_states" in topics(), 60, "/joint_states")
            info = {"process": process, "home": home}
            abuse(info, "valid")  # warm: every code path the checks use has run once
            info["rss_start"] = rss_kb(process.pid)
            yield info
        finally:
            stop(process)


def test_a_thousand_bad_goals_then_a_good_one(node: dict[str, Any]) -> None:
    report = abuse(node, "goals")
    assert report["answered"] >= 990 and set(report["codes"]) <= {0, -1, -2}


def test_a_burst_of_1000_goals_does_not_freeze_the_clock(node: dict[str, Any]) -> None:
    """Issue 29: a burst of 1000 goals froze physics, /clock and /joint_states for seconds. Seeded fault: the
    former drain (every queued callback in one go, ``self._drain()`` in node.py's control update): it failed
    with one run of 904 answers and no /clock between them."""
    report = abuse(node, "burst")
    assert report["answered"] >= 950 and report["longest_run"] < 500


def test_command_flooded_at_1_khz_for_10_s(node: dict[str, Any]) -> None:
    """/joint_states keeps 0.4 of its 50 Hz (or of its rate just before, on a loaded machine) through the flood, and
    the flood costs the node less than 4 MB: each /command replaces the one still waiting for the simulation
    thread (svhdesc.control.work.Latest, as JTC's queue-size-1 subscriber), where every message used to be queued
    and the queue outgrew the 8 items an update works (issue 39: 27 MB in one step). Seeded fault: /command queued
    per message again (ros1/controller.py) -> 14.3 MB grown over the first 1 kHz flood (0.7 MB with the slot)."""
    before = rss_kb(node["process"].pid)
    report = abuse(node, "flood")
    grown = rss_kb(node["process"].pid) - before
    print(f"node RSS grew by {grown / 1024:.1f} MB over the flood")
    assert report["rate"] > 800 and report["joint_states"] > 0.4 * min(50.0, report["calm"])
    assert grown < 4 * 1024, f"{grown / 1024:.1f} MB"


def test_a_client_killed_mid_goal(node: dict[str, Any]) -> None:
    abuse(node, "killed")


def test_a_subscriber_that_stops_reading_does_not_stall_the_node(node: dict[str, Any]) -> None:
    """The node publishes synchronously from its own thread (no rospy queue and thread per subscriber): a socket
    whose subscriber never reads must not block it. Seeded fault: the send timeout left out (svhdesc/ros1/system.py,
    time_out_stalled_subscribers without settimeout): /joint_states stopped for everyone (0.0 Hz)."""
    report = abuse(node, "stalled")
    assert report["joint_states"] > 30


def test_memory_grew_less_than_16_mb(node: dict[str, Any]) -> None:
    """Runs last (file order): everything above has happened to the node by now."""
    abuse(node, "valid")
    grown = rss_kb(node["process"].pid) - node["rss_start"]
    print(f"node RSS grew by {grown / 1024:.1f} MB")
    assert grown < MEMORY_LIMIT_KB, f"{grown / 1024:.1f} MB"
