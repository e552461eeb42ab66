"""``svhdesc sim VARIANT --ros2`` as a client written for SCHUNK's ROS 2 driver sees it (tests/ros2/driver_client.py:
rclpy and the message packages only, nothing of svhdesc): SCHUNK's example flow on ``/<controller>/joint_trajectory``,
Jazzy JTC's topic semantics and its refusals, query_state, the flood.

One node process per variant per session (module-scoped fixture), in a private network namespace (``unshare -n``,
loopback only) with ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST; one client run per variant writes one JSON report and
each test asserts on its part. Seeded faults are in tests/control/test_topic_semantics.py (the controller layer) and
in ``test_seeded_*`` here (the node started with SVHDESC_SEED_FAULT, a test-only switch read by nothing but this
test's subprocess: see svhdesc/ros2/controller.py).
"""

from __future__ import annotations

import json
import shlex
import subprocess
from pathlib import Path
from typing import Any

import pytest

from tests.netns import private_namespace
from tests.ros2.support import PYTHON, private_env, why_not

VARIANTS = ("svh_right", "svh_left", "ur5_svh_right")
CLIENT = Path(__file__).with_name("driver_client.py")
GRAPH = "startup hardware example graph"
CHECKS = {
    "svh_right": f"{GRAPH} semantics bad_input flood",
    "svh_left": f"{GRAPH} semantics",
    "ur5_svh_right": f"{GRAPH} semantics bad_input",
}
# schunk_svh_library's CHANNEL_EFFORT_CONSTANTS (src/control/SVHController.cpp), restated: (a, b) per channel with
# effort = a * |current| + b; Thumb_Opposition and Finger_Spread have none.
LIBRARY = {"Thumb_Flexion": (0.015, -1.543), "Pinky": (0.005, 0.081), "Thumb_Opposition": None, "Finger_Spread": None}
ARM = "scaled_joint_trajectory_controller"

pytestmark = [pytest.mark.ros, pytest.mark.slow]


def serve(variant: str, work: Path, checks: str, faults: str = "") -> dict[str, Any]:
    """One node and one driver_client run for ``variant``; the report and the node's log. ``faults``: Python run in
    the node's process before svhdesc's CLI (seeded faults, monkeypatched)."""
    from svhdesc.model import get

    python = shlex.quote(str(PYTHON))
    (work / "launch.py").write_text(f"{faults}\nfrom svhdesc.cli import main\nmain()\n")
    launcher = shlex.quote(str(work / "launch.py"))
    report = work / "report.json"
    script = f"""
ip link set lo up
{python} {launcher} sim {variant} --ros2 > {work}/node.log 2>&1 &
node=$!
{python} {shlex.quote(str(CLIENT))} {shlex.quote(str(get(variant).directory))} {report} $node {checks} \
  > {work}/client.log 2>&1
kill -INT $node  # ignored if it lands before rclpy's handler (a background job of sh ignores SIGINT): then KILL
for _ in $(seq 100); do kill -0 $node 2>/dev/null || break; sleep 0.1; done
kill -KILL $node 2>/dev/null
"""
    env = private_env(work)
    namespace = private_namespace()
    assert isinstance(namespace, list)
    subprocess.run([*namespace, "sh", "-c", script], env=env, timeout=600, check=False)
    log = (work / "node.log").read_text() if (work / "node.log").exists() else ""
    client_log = (work / "client.log").read_text() if (work / "client.log").exists() else ""
    assert report.exists(), f"no client report\nclient:\n{client_log[-3000:]}\nnode:\n{log[-3000:]}"
    return {"variant": variant, "report": json.loads(report.read_text()), "log": log, "work": work}


@pytest.fixture(scope="module", params=VARIANTS)
def served(request: pytest.FixtureRequest, tmp_path_factory: pytest.TempPathFactory) -> dict[str, Any]:
    why = why_not()
    if why:
        pytest.skip(why)
    variant = request.param
    return serve(variant, tmp_path_factory.mktemp(f"driver-{variant}"), CHECKS[variant])


def part(served: dict[str, Any], name: str) -> Any:
    found = served["report"].get(name)
    if found is None:
        pytest.skip(f"{served['variant']}: {name} is not run on this variant")
    assert not (isinstance(found, dict) and "error" in found), f"{served['variant']}: {name}: {found}"
    return found


def check_startup(served: dict[str, Any]) -> None:
    states = part(served, "startup")["states"]
    hand = served["report"]["hand"]
    assert states.get(hand) == "active" and states.get("joint_state_broadcaster") == "active", states


def check_example(served: dict[str, Any]) -> None:
    found = part(served, "example")
    assert found["nodes_found"] == [served["report"]["hand"]], found
    assert found["references"]["fist"] < 1e-6 and found["references"]["full_spread"] < 1e-6, found
    assert max(found["errors"]["full_spread"].values()) < 0.01, found
    fist = {c: e for c, e in found["errors"]["fist"].items() if not c.endswith("_Thumb_Opposition")}
    assert max(fist.values()) < 0.05, found


def check_graph(served: dict[str, Any]) -> None:
    found = part(served, "graph")
    controllers = list(found["parameters"])
    wanted = {"controller_manager", "robot_state_publisher", "svh", *controllers}
    assert wanted <= set(found["nodes"]), found["nodes"]
    publishers = found["publishers"]
    assert publishers["/joint_states"] == publishers["/dynamic_joint_states"] == ["joint_state_broadcaster"]
    assert publishers["/svh/initialized"] == ["svh"], publishers
    assert publishers["/tf"] == publishers["/robot_description"] == ["robot_state_publisher"], publishers
    for name in served["report"]["controllers"]:
        assert publishers[f"/{name}/controller_state"] == [name], publishers
    services = found["manager_services"]
    assert {"/controller_manager/list_controllers", "/controller_manager/switch_controller"} <= set(services)


def check_parameters(served: dict[str, Any]) -> None:
    for name, read in part(served, "graph")["parameters"].items():
        assert read["read"] == read["expected"], name


def check_controller_state_rate(served: dict[str, Any]) -> None:
    for name, steps in part(served, "graph")["state_steps"].items():
        assert steps == [0.008], (name, steps)


def check_initialized(served: dict[str, Any]) -> None:
    assert part(served, "hardware")["initialized"] is True


def check_dynamic_joint_states(served: dict[str, Any]) -> None:
    found = part(served, "hardware")
    interfaces = found["interfaces"]
    assert set(interfaces) == set(found["system_order"]), sorted(interfaces)
    for channel in found["channels"]:
        values = interfaces[channel]
        order = found["interface_order"][channel]
        assert order == ["position", "velocity", "effort", "current"], (channel, order)
        constants = LIBRARY.get(channel.split("_Hand_", 1)[1], ())
        if constants is None:
            assert values["effort"] == 0.0 and values["current"] != values["current"], values  # NaN: no constants
        elif constants:
            a, b = constants
            assert values["current"] >= 0 and values["effort"] == pytest.approx(a * values["current"] + b), values


def check_joint_order(served: dict[str, Any]) -> None:
    found = part(served, "hardware")
    assert found["joint_states_order"] == found["system_order"], found["joint_states_order"]


def check_tf(served: dict[str, Any]) -> None:
    found = part(served, "hardware")
    assert found["description_robot"] == served["variant"]
    assert found["tf"] == found["tf_expected"] and found["tf"], found["tf"]
    assert found["tf_static"] == found["tf_static_expected"], found["tf_static"]


def test_startup_lists_the_hand_controller_and_the_broadcaster_active(served: dict[str, Any]) -> None:
    """SCHUNK's test_startup.py: list_controllers shows the hand controller and joint_state_broadcaster active."""
    check_startup(served)


def test_schunk_example_presets_reach_the_channels(served: dict[str, Any]) -> None:
    """SCHUNK's scripts/example.py: the hand controller found by its node name (``/right_hand`` or ``/left_hand``
    in the graph), the fist and the full spread published on /<controller>/joint_trajectory. The controller's
    reference (~/controller_state) ends exactly on each preset; every channel reaches the full spread (0.01 rad) and
    the fist (0.05 rad) except Thumb_Opposition, which the simulated fist stops near 0.21 rad: the thumb meets the
    hand (a contact, seen in the simulation alone) before 0.6."""
    check_example(served)


def test_the_graph_of_a_ros2_control_system(served: dict[str, Any]) -> None:
    """A node per controller named after it, controller_manager serving its services under its own name,
    joint_state_broadcaster publishing joint_states and dynamic_joint_states, robot_state_publisher /tf and
    /robot_description, svh /svh/initialized, each controller its own ~/controller_state."""
    check_graph(served)


def test_controller_parameters_read_by_a_parameter_client(served: dict[str, Any]) -> None:
    """Each controller node's parameters (GetParameters) equal the generated ros2_controllers.yaml's, dotted
    (``constraints.<joint>.goal``) as ros2_control's --params-file gives them."""
    check_parameters(served)


def test_controller_state_at_the_update_rate(served: dict[str, Any]) -> None:
    """~/controller_state every update: stamps 1/125 s apart."""
    check_controller_state_rate(served)


def test_svh_initialized_latched_true(served: dict[str, Any]) -> None:
    """/svh/initialized: a late (transient local) subscriber gets true."""
    check_initialized(served)


def test_dynamic_joint_states_carry_schunks_state_interfaces(served: dict[str, Any]) -> None:
    """/dynamic_joint_states: every ros2_control joint; each channel position, velocity, effort, current (SCHUNK's
    export_state_interfaces order); the effort is the library's convertmAtoN of the current."""
    check_dynamic_joint_states(served)


def test_joint_states_in_the_systems_order(served: dict[str, Any]) -> None:
    """joint_states lists the joints in the ros2_control system's order (the generated ros2_control xacro)."""
    check_joint_order(served)


def test_tf_and_the_robot_description(served: dict[str, Any]) -> None:
    """/robot_description (transient local) is the variant's URDF; /tf has a transform per moving URDF joint,
    /tf_static (transient local) one per fixed joint, named by the URDF's links."""
    check_tf(served)


def test_topic_semantics_as_jazzy_jtc(served: dict[str, Any]) -> None:
    """A partial topic trajectory moves the named joint and leaves the others (hand: allow_partial_joints_goal);
    a repeated name counts once (its first column, as the goals read it); a new trajectory replaces a running one
    (the joints end at the newer target); a topic trajectory during an action goal does not end the goal: Jazzy's
    update() judges the goal against the topic's trajectory, so it succeeds (code 0) once the joints reach it."""
    found = part(served, "semantics")
    assert found["partial"]["named"] < 0.03 and found["partial"]["others"] < 0.01, found["partial"]
    assert found["repeated_first_wins"] < 0.03, found
    assert found["replaced"] < 0.03, found
    goal = found["goal_then_topic"]
    assert goal["status"] == 4 and goal["error_code"] == 0, goal  # action_msgs STATUS_SUCCEEDED
    assert goal["error"] < 0.03, goal


def test_query_state_answers_during_a_trajectory_only(served: dict[str, Any]) -> None:
    """~/query_state (control_msgs/srv/QueryTrajectoryState) as Jazzy's: success with every joint of the controller
    while the current trajectory runs; after its end success is false (Jazzy's query_state_service)."""
    query = part(served, "semantics")["query_state"]
    assert query["during"]["success"] and query["during"]["size"] == len(query["during"]["names"]) > 0, query
    assert not query["after"]["success"], query


def test_malformed_topic_trajectories_are_rejected(served: dict[str, Any]) -> None:
    """Unknown, ROS 1-named, repeated (where that leaves joints out), missing joints, NaN, non-increasing times, a
    wrong size, no points, no joints, a moving end, efforts: each is logged as rejected and nothing moves; the
    node keeps serving (the later checks and the flood's last trajectory)."""
    found = part(served, "bad_input")
    for case, result in found.items():
        if case.endswith("/repeated_joint") and not case.startswith(ARM):
            continue  # the hand allows partial trajectories: a repeated name counts once (test_topic_semantics)
        assert result["moved"] < 0.005 and result["logged"], (case, result)


def test_a_flood_of_topic_trajectories(served: dict[str, Any]) -> None:
    """1 kHz of topic trajectories for 10 s (every tenth malformed): the node's memory stays flat (within 20 MB of
    where it was after the first second), /clock never stops for more than 0.5 s of wall time, and a trajectory
    after the flood still moves the hand."""
    found = part(served, "flood")
    assert found["sent"] >= 5000, found
    memory = found["rss_kb"]
    assert max(memory[1:]) - memory[1] < 20_000, memory
    assert found["clock_gap"] < 0.5 and found["clock_messages"] > 100, found
    assert found["after"] < 0.03, found


FAULTS = """
import numpy
import svhdesc.ros2.controller as controller
import svhdesc.ros2.graph as graph
import svhdesc.ros2.hardware as hardware
import svhdesc.ros2.node as node

hardware.CHANNEL_INTERFACES = ("velocity", "position", "effort", "current")
hardware.SETTLE_LONGEST, hardware.SETTLE_SPEED = float("inf"), -1.0
node.system_joints = lambda path: sorted(graph.system_joints(path))
real_node_with = node.node_with
node.node_with = lambda rclpy, name, parameters: real_node_with(
    rclpy, name if name in ("svhdesc_sim", "controller_manager") else "x_" + name, {}
)
graph.StatePublisher.publish = lambda self, *reading: None
controller.TrajectoryController.on_topic = lambda self, goal: None
real_state = controller.TrajectoryController._publish_state
published = [0]


def every_second(self, sample):
    published[0] += 1
    if published[0] % 2:
        real_state(self, sample)


controller.TrajectoryController._publish_state = every_second
"""


def test_seeded_faults_fail_the_checks(tmp_path: Path) -> None:
    """svh_right's node with seeded faults (monkeypatched in its process): the channels' interfaces reordered, no
    settling, joint_states sorted by name, the controller nodes renamed and declaring nothing, no /tf, topic
    trajectories dropped, every second controller_state dropped: each check above fails on that report;
    list_controllers (no fault) still passes."""
    why = why_not()
    if why:
        pytest.skip(why)
    faulty = serve("svh_right", tmp_path, "startup hardware example graph", FAULTS)
    check_startup(faulty)
    failing = [
        check_example,
        check_graph,
        check_parameters,
        check_controller_state_rate,
        check_initialized,
        check_dynamic_joint_states,
        check_joint_order,
        check_tf,
    ]
    for check in failing:
        with pytest.raises(AssertionError):
            check(faulty)
