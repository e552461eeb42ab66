"""The ROS 2 node as a library: ``svhdesc.ros2.node.serve`` on a Simulation the caller built (its scene edited: the
hand turned over and raised, a fixed marker and a free cube added), publishing the poses of named bodies, while an
independent rclpy client (tests/ros2/client.py --tracker, no svhdesc code) reads ``/tracked/<body>`` and drives the
hand through its forward position controller. Inside ``unshare -n`` with ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST,
both in the ROS 2 venv's Python, as tests/ros2/test_node.py.

Seeded faults (each failed the test, then reverted): the tracker writing the quaternion as (x, y, z, w) -> the
marker's orientation; frame_id "map" -> frames; the poses published every second update -> steps of 0.016 s; the
edit not applied (``Simulation(variant)``) -> no body "marker", the node exits 2 with one error line.
"""

from __future__ import annotations

import json
import math
import shlex
import subprocess
from typing import Any

import pytest

from tests.netns import private_namespace
from tests.ros2.support import CLIENT, PYTHON, private_env, why_not

pytestmark = [pytest.mark.ros, pytest.mark.slow]

MARKER = (0.3, -0.2, 0.5)
TURN = math.pi / 4  # the marker's yaw
RAISED = 0.4  # the hand's root, turned half a turn about x (palm up, fingers down)
CUBE = 0.025  # half the cube's edge

NODE = f"""
import sys
import mujoco
from svhdesc.ros2.node import serve
from svhdesc.sim import Simulation

def edit(spec):
    root = spec.body("svh_right_root")
    root.pos, root.quat = [0, 0, {RAISED}], [0, 1, 0, 0]
    yaw = [{math.cos(TURN / 2)}, 0, 0, {math.sin(TURN / 2)}]
    marker = spec.worldbody.add_body(name="marker", pos={list(MARKER)}, quat=yaw)
    marker.add_geom(type=mujoco.mjtGeom.mjGEOM_SPHERE, size=[0.01, 0, 0], contype=0, conaffinity=0)
    cube = spec.worldbody.add_body(name="cube", pos=[0.4, 0.4, 0.2])
    cube.add_freejoint()
    cube.add_geom(type=mujoco.mjtGeom.mjGEOM_BOX, size=[{CUBE}] * 3, mass=0.1)

sim = Simulation("svh_right", edit=edit)
serve(sim, track=["marker", "cube", "right_hand_base_link"], duration=float(sys.argv[1]))
"""


@pytest.fixture(scope="module")
def tracked(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Any]:
    why = why_not()
    if why:
        pytest.skip(why)
    from svhdesc.model import get

    work = tmp_path_factory.mktemp("ros2-library")
    (work / "node.py").write_text(NODE)
    python, client = shlex.quote(str(PYTHON)), shlex.quote(str(CLIENT))
    report = work / "report.json"
    variant_dir = shlex.quote(str(get("svh_right").directory))
    script = f"""
ip link set lo up
{python} {work}/node.py 600 > {work}/node.log 2>&1 &
node=$!
{python} {client} --tracker {variant_dir} {report} marker cube right_hand_base_link > {work}/client.log 2>&1
echo "client $?" > {work}/exits
kill -INT $node
wait $node
echo "node $?" >> {work}/exits
"""
    namespace = private_namespace()
    assert isinstance(namespace, list)
    subprocess.run([*namespace, "sh", "-c", script], env=private_env(work), timeout=300, check=False)
    log = (work / "node.log").read_text() if (work / "node.log").exists() else ""
    client_log = (work / "client.log").read_text() if (work / "client.log").exists() else ""
    assert report.exists(), f"no client report\nclient:\n{client_log[-3000:]}\nnode:\n{log[-3000:]}"
    exits = dict(line.split() for line in (work / "exits").read_text().splitlines())
    return {"report": json.loads(report.read_text()), "exits": exits, "log": log}


def test_tracked_bodies_are_posestamped_in_world_at_the_update_rate(tracked: dict[str, Any]) -> None:
    """Each tracked body: PoseStamped in frame "world" every control update (125 Hz of simulated time: every stamp
    step a whole 8 ms period, most of them one); the fixed marker exactly where the edit put it, (w, x, y, z) as
    the edit's quaternion; the turned hand's base link at the raised root, turned half a turn about x; the cube
    fallen from 0.2 m to rest on the scene's floor (its centre half an edge above it)."""
    report = tracked["report"]
    for body in ("marker", "cube", "right_hand_base_link"):
        found = report[body]
        assert found["count"] >= 150 and found["frames"] == ["world"], found
        assert all(abs(step / 0.008 - round(step / 0.008)) < 1e-3 and step > 0 for step in found["steps"]), found
    marker = report["marker"]
    assert marker["position"] == pytest.approx(list(MARKER), abs=1e-9)
    assert marker["orientation"] == pytest.approx([math.cos(TURN / 2), 0, 0, math.sin(TURN / 2)], abs=1e-9)
    hand = report["right_hand_base_link"]
    assert hand["position"] == pytest.approx([0, 0, RAISED], abs=1e-6)
    assert [abs(q) for q in hand["orientation"]] == pytest.approx([0, 1, 0, 0], abs=1e-6)
    import mujoco

    from svhdesc.model import get

    floor = float(mujoco.MjModel.from_xml_path(str(get("svh_right").scene_path)).geom("floor").pos[2])
    cube = report["cube"]
    assert cube["position"][2] == pytest.approx(floor + CUBE, abs=2e-3), cube


def test_the_library_node_is_driven_through_its_forward_controller(tracked: dict[str, Any]) -> None:
    """On the library-started node the hand's forward_position_controller, swapped in for the trajectory controller,
    brings every channel within 0.05 rad of its command in 2 s; SIGINT ends serve() and the script with exit 0."""
    report = tracked["report"]
    assert report["swapped"] and max(report["errors"]) < 0.05, report["errors"]
    assert tracked["exits"] == {"client": "0", "node": "0"}, tracked["log"][-2000:]
    assert "Traceback" not in tracked["log"]
