"""The ROS 1 node against a real rosmaster: drivers' interfaces, JTC semantics, connector, launch.

One master, one roslaunch of the generated ur5_svh_right launch file (node + robot_state_publisher,
as fast as possible on simulated time) and one in-process rospy client serve the whole module.
"""

from __future__ import annotations

import math
import os
import subprocess
import sys
import threading
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml

import svhdesc
from svhdesc.model import DRIVER_CHANNELS
from svhdesc.ros1.system import ros_available
from tests.rosmaster import master, shut_down_if_it_dies, simple_action_client, stop, svhdesc_executable, wait_for
from tests.support import REPO, run_cli

pytestmark = pytest.mark.skipif(not ros_available(), reason="Debian's python3-rospy is not installed")

VARIANT = "ur5_svh_right"
HAND = "right_hand_controller"
ARM = "scaled_pos_joint_traj_controller"
HAND_FORWARD = "right_hand_forward_position_controller"  # beside the arm's forward_position_controller
ARM_JOINTS = [
    "shoulder_pan_joint",
    "shoulder_lift_joint",
    "elbow_joint",
    "wrist_1_joint",
    "wrist_2_joint",
    "wrist_3_joint",
]
GOAL_MD5 = "cff5c1d533bf2f82dd0138d57f4304bb"  # control_msgs/FollowJointTrajectoryActionGoal on ROS 1


class Latest:
    """The last message (and every message, if asked) on a topic."""

    def __init__(self, rospy: Any, topic: str, kind: Any, keep: bool = False) -> None:
        self.message: Any = None
        self.all: list[Any] = []
        self._keep = keep
        self._lock = threading.Lock()
        self.subscriber = rospy.Subscriber(topic, kind, self._on, queue_size=100)

    def _on(self, message: Any) -> None:
        with self._lock:
            self.message = message
            if self._keep:
                self.all.append(message)

    def fresh(self, timeout: float = 10.0) -> Any:
        """A message received after this call."""
        with self._lock:
            before = self.message
        return wait_for(lambda: self.message is not before and self.message, timeout, "a new message")


@pytest.fixture(scope="module")
def ros(tmp_path_factory: pytest.TempPathFactory) -> Iterator[dict[str, Any]]:
    from svhdesc.ros1.messages import control_msgs
    from svhdesc.ros1.system import import_ros

    rospy = import_ros()
    home = tmp_path_factory.mktemp("roshome")
    with master(home) as env:
        rospy.set_param("/use_sim_time", True)
        model = svhdesc.get(VARIANT)
        launch = subprocess.Popen(
            ["roslaunch", str(model.directory / "launch" / "sim.launch"), "pace:=as-fast"],
            env={
                **env,
                "PATH": "/usr/bin:/bin",
                "ROS_PACKAGE_PATH": str(model.directory.parent),
                "SVHDESC": svhdesc_executable(),
                # The checkout under test, also where it is on PYTHONPATH rather than installed.
                **({"PYTHONPATH": os.environ["PYTHONPATH"]} if "PYTHONPATH" in os.environ else {}),
            },
            stdout=(home / "launch.out").open("w"),
            stderr=subprocess.STDOUT,
        )
        try:
            rospy.init_node("svhdesc_test", anonymous=True, disable_signals=True)
            from sensor_msgs.msg import JointState

            states = Latest(rospy, "/joint_states", JointState)
            wait_for(lambda: states.message, 60, "/joint_states from the launched node")
            with shut_down_if_it_dies(launch, rospy):
                yield {"rospy": rospy, "msgs": control_msgs(), "states": states, "home": home, "launch": launch}
        finally:
            stop(launch)


def _keyframe(name: str) -> dict[str, float]:

    model = svhdesc.load_mujoco(VARIANT)
    key = model.key(name)
    return {model.actuator(a).name: float(key.ctrl[a]) for a in range(model.nu)}


def _goal(
    ros: dict[str, Any], joints: list[str], positions: list[list[float]], times: list[float], **extra: Any
) -> Any:
    from trajectory_msgs.msg import JointTrajectoryPoint

    goal = ros["msgs"].FollowJointTrajectoryGoal()
    goal.trajectory.joint_names = joints
    for p, t in zip(positions, times):
        goal.trajectory.points.append(JointTrajectoryPoint(positions=p, time_from_start=ros["rospy"].Duration(t)))
    for key, value in extra.items():
        setattr(goal, key, value)
    return goal


def _client(ros: dict[str, Any], controller: str) -> Any:
    client = simple_action_client(f"/{controller}/follow_joint_trajectory", ros["msgs"].FollowJointTrajectoryAction)
    assert client.wait_for_server(ros["rospy"].Duration(30)), controller
    return client


def _send(ros: dict[str, Any], controller: str, goal: Any, wait: float = 60.0) -> tuple[int, Any]:
    client = _client(ros, controller)
    client.send_goal(goal)
    assert client.wait_for_result(ros["rospy"].Duration(wait)), "no result"
    return client.get_state(), client.get_result()


def _positions(ros: dict[str, Any]) -> dict[str, float]:
    message = ros["states"].fresh()
    return dict(zip(message.name, message.position))


def _at_rest(
    ros: dict[str, Any], joints: list[str], tolerance: float = 2e-4, timeout: float = 120.0
) -> dict[str, float]:
    """The positions once ``joints`` moved less than ``tolerance`` over 0.2 s of simulated time. Waits on the
    node's simulated time, never a fixed sleep; the wall-clock deadline is generous because on a loaded machine
    the node runs slower."""
    reference = ros["states"].fresh()

    def settled() -> dict[str, float] | None:
        nonlocal reference
        message = ros["states"].fresh()
        if (message.header.stamp - reference.header.stamp).to_sec() < 0.2:
            return None
        before, now = dict(zip(reference.name, reference.position)), dict(zip(message.name, message.position))
        reference = message
        return now if all(abs(now[j] - before[j]) < tolerance for j in joints) else None

    return wait_for(settled, timeout, f"{joints} at rest")


def test_goal_message_md5_matches_a_real_ros_system() -> None:
    from svhdesc.ros1.messages import control_msgs

    msgs = control_msgs()
    assert msgs.FollowJointTrajectoryActionGoal._md5sum == GOAL_MD5
    assert msgs.FollowJointTrajectoryActionGoal._type == "control_msgs/FollowJointTrajectoryActionGoal"
    assert msgs.FollowJointTrajectoryResult.INVALID_JOINTS == -2


def test_home_to_test_on_arm_and_hand(ros: dict[str, Any]) -> None:
    from actionlib_msgs.msg import GoalStatus

    test = _keyframe("test")
    arm = ARM_JOINTS
    hand = [n for n in test if n.startswith("right_hand_")]
    assert len(hand) == 9
    clients = {}
    for controller, joints in ((ARM, arm), (HAND, hand)):
        clients[controller] = _client(ros, controller)
        clients[controller].send_goal(_goal(ros, joints, [[test[j] for j in joints]], [4.0]))
    for controller, client in clients.items():
        assert client.wait_for_result(ros["rospy"].Duration(60)), controller
        assert client.get_state() == GoalStatus.SUCCEEDED, (controller, client.get_goal_status_text())
        assert client.get_result().error_code == 0
    ros["rospy"].sleep(0.5)  # simulated time
    positions = _positions(ros)
    assert len(positions) == 26
    for joint, target in test.items():
        assert abs(positions[joint] - target) < 2e-3, joint
    spec = yaml.safe_load((REPO / "config" / "coupling.yaml").read_text())
    for coupling in spec["couplings"]:
        channel = positions[f"right_hand_{coupling['follows']}"]
        expected = sum(c * channel**k for k, c in enumerate(coupling["poly"]))
        assert positions[f"right_hand_{coupling['joint']}"] == pytest.approx(expected, abs=1e-3), coupling["joint"]


def test_bad_goals_are_rejected_with_jtc_error_codes(ros: dict[str, Any]) -> None:
    from actionlib_msgs.msg import GoalStatus

    result = ros["msgs"].FollowJointTrajectoryResult
    wait_for(lambda: ros["rospy"].Time.now().to_sec() > 1.0, 30, "one simulated second")
    channels = [f"right_hand_{c}" for c in DRIVER_CHANNELS]
    old = _goal(ros, ["right_hand_Pinky"], [[0.1]], [0.5])
    old.trajectory.header.stamp = ros["rospy"].Time.from_sec(0.1)  # ended at t = 0.6 s
    # noetic's JTC never answers OLD_HEADER_TIMESTAMP: all points in the past is INVALID_GOAL.
    cases = [
        (HAND, _goal(ros, ["right_hand_j12"], [[0.1]], [1.0]), result.INVALID_JOINTS),  # coupled: not a channel
        (ARM, _goal(ros, ["shoulder_pan_joint"], [[0.1]], [1.0]), result.INVALID_JOINTS),  # arm: all six or none
        (HAND, _goal(ros, ["right_hand_Pinky"], [[math.nan]], [1.0]), result.INVALID_GOAL),
        (HAND, _goal(ros, ["right_hand_Pinky"], [[3.0]], [1.0]), result.INVALID_GOAL),  # beyond its limit
        (HAND, _goal(ros, ["right_hand_Pinky"], [[0.1], [0.2]], [1.0, 0.5]), result.INVALID_GOAL),
        (HAND, _goal(ros, ["right_hand_Pinky", "right_hand_Ring_Finger"], [[0.1]], [1.0]), result.INVALID_GOAL),
        (HAND, old, result.INVALID_GOAL),
        (HAND, _goal(ros, ["right_hand_Pinky"], [[0.1], [0.2]], [1.0, 1.0]), result.INVALID_GOAL),  # not increasing
        # more names than joints (a channel twice; an arm joint twice): noetic's mapping fails (issue 39)
        (HAND, _goal(ros, [*channels, channels[0]], [[0.1] * 10], [1.0]), result.INVALID_JOINTS),
        (ARM, _goal(ros, [*ARM_JOINTS, ARM_JOINTS[0]], [[0.0] * 7], [1.0]), result.INVALID_JOINTS),
    ]
    for controller, goal, code in cases:
        state, outcome = _send(ros, controller, goal)
        assert state == GoalStatus.REJECTED and outcome.error_code == code, (goal.trajectory, outcome)
        assert outcome.error_string
    _, outcome = _send(ros, HAND, old)
    assert outcome.error_string.startswith("Dropping all 1 trajectory point(s), as they occur before the current")
    # A repeated name is accepted as JTC does; its first column counts.
    state, _ = _send(ros, HAND, _goal(ros, ["right_hand_Pinky", "right_hand_Pinky"], [[0.1, 0.2]], [0.5]))
    assert state == GoalStatus.SUCCEEDED
    positions = _positions(ros)
    assert all(math.isfinite(v) for v in positions.values())


def test_tolerance_violations_abort(ros: dict[str, Any]) -> None:
    from actionlib_msgs.msg import GoalStatus

    tolerance = ros["msgs"].JointTolerance
    result = ros["msgs"].FollowJointTrajectoryResult
    positions = _positions(ros)
    arm = ARM_JOINTS
    start = [positions[j] for j in arm]
    moved = [start[0] - 0.3, *start[1:]]
    goal = _goal(ros, arm, [moved], [1.0], path_tolerance=[tolerance(name="shoulder_pan_joint", position=1e-5)])
    state, outcome = _send(ros, ARM, goal)
    assert state == GoalStatus.ABORTED and outcome.error_code == result.PATH_TOLERANCE_VIOLATED
    # The spread rests on its limit margin, 2 mrad above 0: a 1 urad goal tolerance cannot be met.
    goal = _goal(
        ros,
        ["right_hand_Finger_Spread"],
        [[0.0]],
        [0.2],
        goal_tolerance=[tolerance(name="right_hand_Finger_Spread", position=1e-6)],
        goal_time_tolerance=ros["rospy"].Duration(0.2),
    )
    state, outcome = _send(ros, HAND, goal)
    assert state == GoalStatus.ABORTED and outcome.error_code == result.GOAL_TOLERANCE_VIOLATED


def test_preemption_cancel_and_partial_hand_goals(ros: dict[str, Any]) -> None:
    from actionlib_msgs.msg import GoalStatus

    rospy = ros["rospy"]
    before = _positions(ros)
    first, second = _client(ros, HAND), _client(ros, HAND)
    first.send_goal(_goal(ros, ["right_hand_Pinky"], [[0.9]], [20.0]))
    wait_for(lambda: first.get_state() == GoalStatus.ACTIVE, 30, "the first goal to start")
    second.send_goal(_goal(ros, ["right_hand_Pinky"], [[0.3]], [0.5]))  # a partial goal: one channel
    assert second.wait_for_result(rospy.Duration(60))
    assert second.get_state() == GoalStatus.SUCCEEDED
    assert first.wait_for_result(rospy.Duration(10)) and first.get_state() == GoalStatus.PREEMPTED
    rospy.sleep(0.3)
    after = _positions(ros)
    # 5 mrad as the hold checks below: a busy machine starts the second goal later in sim time, and the Pinky's servo
    # was seen 2.4 mrad short 0.3 s after success (its goal tolerance is wider).
    assert after["right_hand_Pinky"] == pytest.approx(0.3, abs=5e-3)
    assert after["right_hand_Thumb_Flexion"] == pytest.approx(before["right_hand_Thumb_Flexion"], abs=2e-3)

    first.send_goal(_goal(ros, ["right_hand_Pinky"], [[0.9]], [20.0]))
    wait_for(lambda: first.get_state() == GoalStatus.ACTIVE, 30, "a goal to start")
    rospy.sleep(2.0)
    first.cancel_goal()
    assert first.wait_for_result(rospy.Duration(10)) and first.get_state() == GoalStatus.PREEMPTED
    held = _positions(ros)["right_hand_Pinky"]
    assert 0.3 < held < 0.9  # canceled midway
    rospy.sleep(1.0)
    assert _positions(ros)["right_hand_Pinky"] == pytest.approx(held, abs=5e-3)  # and held there


def test_an_empty_goal_stops_where_the_hand_is(ros: dict[str, Any]) -> None:
    from actionlib_msgs.msg import GoalStatus

    rospy = ros["rospy"]
    moving = _client(ros, HAND)
    moving.send_goal(_goal(ros, ["right_hand_Ring_Finger"], [[0.9]], [20.0]))
    wait_for(lambda: moving.get_state() == GoalStatus.ACTIVE, 30, "a goal to start")
    rospy.sleep(1.5)
    state, result = _send(ros, HAND, _goal(ros, ["right_hand_Ring_Finger"], [], []))
    assert state == GoalStatus.SUCCEEDED and result.error_code == 0
    assert moving.wait_for_result(rospy.Duration(10)) and moving.get_state() == GoalStatus.PREEMPTED
    # Held from 0.5 simulated s on: on a busy machine this client's newest /joint_states can lag the node, so a
    # snapshot taken at the result may predate the stop. Still moving, the finger would go 45 mrad in the next 1 s.
    rospy.sleep(0.5)
    held = _positions(ros)["right_hand_Ring_Finger"]
    rospy.sleep(1.0)
    assert _positions(ros)["right_hand_Ring_Finger"] == pytest.approx(held, abs=5e-3)
    # Unknown joints are still refused first, as the controller does.
    state, result = _send(ros, HAND, _goal(ros, ["no_such_joint"], [], []))
    assert state == GoalStatus.REJECTED and result.error_code == ros["msgs"].FollowJointTrajectoryResult.INVALID_JOINTS


def test_command_topic_and_connector_topics(ros: dict[str, Any]) -> None:
    from std_msgs.msg import Float64
    from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint

    rospy = ros["rospy"]
    connector = yaml.safe_load((svhdesc.get(VARIANT).directory / "config" / "connector.yaml").read_text())
    entry = {e["name"]: e for e in connector["joints"]}
    assert len(entry) == 15 and {"p_gain", "d_gain", "control_topic", "pose_topic", "initpose_topic"} <= set(
        entry["right_hand_Ring_Finger"]
    )
    ring = entry["right_hand_Ring_Finger"]
    pose = Latest(rospy, ring["pose_topic"], Float64)
    initpose = rospy.Publisher(ring["initpose_topic"], Float64, queue_size=1)
    control = rospy.Publisher(ring["control_topic"], Float64, queue_size=1)
    wait_for(lambda: initpose.get_num_connections() and control.get_num_connections(), 20, "connector subscribers")
    initpose.publish(Float64(0.6))
    wait_for(lambda: abs(_positions(ros)["right_hand_Ring_Finger"] - 0.6) < 5e-3, 20, "initpose to reset the joint")
    positions = _positions(ros)
    assert positions["right_hand_j12"] == pytest.approx(1.3588 * positions["right_hand_Ring_Finger"], abs=2e-3)
    control.publish(Float64(math.nan))  # refused; the joint stays
    control.publish(Float64(0.2))
    wait_for(lambda: abs(pose.fresh().data - 0.2) < 3e-3, 30, "the pose topic to report the new target")

    command = rospy.Publisher(f"/{HAND}/command", JointTrajectory, queue_size=1)
    wait_for(lambda: command.get_num_connections(), 20, "the command subscriber")
    bad = JointTrajectory(joint_names=["right_hand_Pinky", "nope"])
    bad.points.append(JointTrajectoryPoint(positions=[0.1, 0.1], time_from_start=rospy.Duration(0.2)))
    command.publish(bad)
    good = JointTrajectory(joint_names=["right_hand_Pinky"])
    good.points.append(JointTrajectoryPoint(positions=[0.45], time_from_start=rospy.Duration(0.3)))
    command.publish(good)
    wait_for(lambda: abs(_positions(ros)["right_hand_Pinky"] - 0.45) < 3e-3, 30, "the command to move the pinky")
    assert all(math.isfinite(v) for v in _positions(ros).values())


def test_clock_tracked_pose_and_fingertip_wrench(ros: dict[str, Any]) -> None:
    from geometry_msgs.msg import WrenchStamped
    from rosgraph_msgs.msg import Clock

    rospy = ros["rospy"]
    clock = Latest(rospy, "/clock", Clock)
    first = clock.fresh().clock.to_sec()
    assert wait_for(lambda: clock.fresh().clock.to_sec() > first, 10, "/clock to advance")
    wrench = Latest(rospy, "/right_hand_t_force", WrenchStamped).fresh()
    assert wrench.header.frame_id == "right_hand_t"  # the URDF's F3D frameName
    assert all(math.isfinite(v) for v in (wrench.wrench.force.x, wrench.wrench.torque.z))


def test_the_node_keeps_ros_time_without_subscribing_to_its_own_clock(ros: dict[str, Any]) -> None:
    """The node sets its ROS time itself (no /clock subscription of its own: a rospy thread and callback per
    message); actionlib's status, stamped with the node's ROS time, still carries simulated time. Seeded faults:
    the subscription kept (the node listed among /clock's subscribers); the time no longer set (status stamps
    stayed at 0)."""
    import rosgraph
    from actionlib_msgs.msg import GoalStatusArray
    from rosgraph_msgs.msg import Clock

    from svhdesc.model import NODE_NAME

    _, subscribers, _ = rosgraph.Master("/svhdesc_test").getSystemState()
    assert not [nodes for topic, nodes in subscribers if topic == "/clock" and f"/{NODE_NAME}" in nodes]
    rospy = ros["rospy"]
    clock = Latest(rospy, "/clock", Clock)
    status = Latest(rospy, "/right_hand_controller/follow_joint_trajectory/status", GoalStatusArray)
    clock.fresh(), status.fresh()  # both connected
    # A busy /clock subscriber reads from a socket that may hold seconds of simulated time (thousands of
    # messages a wall second at pace as-fast), so its latest message is a lower bound on the node's time: the
    # status stamp is at or after it, and far below wall time.
    before = clock.fresh().clock.to_sec()
    stamp = status.fresh().header.stamp.to_sec()
    after = clock.fresh().clock.to_sec()
    assert before - 0.5 <= stamp <= after + 60.0, (before, stamp, after)


def test_tf_from_robot_state_publisher_covers_every_frame(ros: dict[str, Any]) -> None:
    from lxml import etree

    from svhdesc.ros1.messages import dynamic_class

    rospy = ros["rospy"]
    tf_message = dynamic_class("tf2_msgs/TFMessage", "geometry_msgs/TransformStamped[] transforms\n")
    seen: set[str] = set()
    subscribers = [
        rospy.Subscriber(topic, tf_message, lambda m: seen.update(t.child_frame_id for t in m.transforms))
        for topic in ("/tf", "/tf_static")
    ]
    links = {link.get("name") for link in etree.parse(str(svhdesc.get(VARIANT).urdf_path)).iterfind("link")}
    links.discard("world")  # the root: a parent, never a child
    try:
        wait_for(lambda: links <= seen, 30, f"tf frames {sorted(links - seen)[:5]}")
    finally:
        for subscriber in subscribers:
            subscriber.unregister()


def test_node_survived_and_logged_reasons(ros: dict[str, Any]) -> None:
    from rosgraph_msgs.msg import Log

    assert ros["launch"].poll() is None, "roslaunch (a required node) exited"
    log = Latest(ros["rospy"], "/rosout", Log, keep=True)
    # Provoke one more rejection and look for its logged reason.
    from std_msgs.msg import Float64

    publisher = ros["rospy"].Publisher("/mujoco/right_hand_Pinky/control", Float64, queue_size=1)

    def logged(text: str, value: float) -> bool:
        # Publish until the node's own /rosout connection to us carries the answer.
        publisher.publish(Float64(value))
        return any(text in m.msg and m.level >= Log.WARN and m.name.endswith("svhdesc_sim") for m in log.all)

    wait_for(lambda: logged("inf is not finite", math.inf), 30, "a logged reason", period=0.2)
    wait_for(lambda: logged("5.0 is not finite or outside", 5.0), 30, "the range reason", period=0.2)
    assert np.all(np.isfinite(list(_positions(ros).values())))


def test_cli_without_a_master_says_so(tmp_path: Path) -> None:
    from tests.rosmaster import free_port

    env = {**os.environ, "ROS_MASTER_URI": f"http://127.0.0.1:{free_port()}", "ROS_HOME": str(tmp_path)}
    result = subprocess.run(
        [svhdesc_executable(), "sim", "svh_right", "--ros"], env=env, capture_output=True, text=True, timeout=120
    )
    assert result.returncode == 2 and result.stderr.startswith("error: no ROS master at http://127.0.0.1:")


def test_cli_refuses_bad_connector_without_traceback(tmp_path: Path) -> None:
    bad = tmp_path / "connector.yaml"
    bad.write_text("joints:\n- {name: right_hand_Pinky, p_gain: -1}\n")
    for path, culprit in ((bad, "connector.yaml"), (tmp_path / "missing.yaml", "missing.yaml")):
        result = run_cli("sim", VARIANT, "--ros", "--connector", str(path), in_process=True)  # refused before init_node
        assert result.returncode == 2 and result.stderr.startswith("error:") and culprit in result.stderr
        assert "Traceback" not in result.stderr


def test_missing_ros_names_the_apt_packages() -> None:
    """Run where the venv cannot see Debian's dist-packages (pointed elsewhere): one clear error."""
    code = (
        "import sys\n"
        "import svhdesc.ros1.system as system\n"
        "system.DIST_PACKAGES = '/nonexistent'\n"
        "sys.path = [p for p in sys.path if 'dist-packages' not in p]\n"
        "try:\n"
        "    system.import_ros()\n"
        "except system.SvhdescError as exc:\n"
        "    print(exc)\n"
        "    assert sys.path[-1] == '/nonexistent'\n"  # appended, never ahead of the venv
    )
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    assert result.returncode == 0, result.stderr
    assert "apt-get install" in result.stdout and "python3-rospy" in result.stdout


def test_hand_only_variant_in_a_namespace(ros: dict[str, Any]) -> None:
    """svh_left beside the running arm: its names under /left, its clock remapped away from /clock."""
    from actionlib_msgs.msg import GoalStatus
    from sensor_msgs.msg import JointState

    rospy = ros["rospy"]
    node = subprocess.Popen(
        # A duration it never reaches (stopped below): on a loaded machine starting it can take long.
        [svhdesc_executable(), "sim", "svh_left", "--ros", "--realtime", "--duration", "600"]
        + ["__ns:=/left", "__name:=left_sim", "/clock:=/left/clock"],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    try:
        states = Latest(rospy, "/left/joint_states", JointState)
        names = wait_for(lambda: states.message, 60, "/left/joint_states").name
        assert len(names) == 20 and all(n.startswith("left_hand_") for n in names)
        client = simple_action_client(
            "/left/left_hand_controller/follow_joint_trajectory", ros["msgs"].FollowJointTrajectoryAction
        )
        assert client.wait_for_server(rospy.Duration(60))
        client.send_goal(
            _goal(ros, ["left_hand_Pinky"], [[0.5]], [2.0])
        )  # within the real pinky's 0.98 rad/s (the model's makes ~0.4)
        wait_for(lambda: client.get_state() == GoalStatus.SUCCEEDED, 30, "the left hand's goal")
        # SCHUNK's controller reports success at the trajectory's end, the finger may still be on its way.
        wait_for(
            lambda: abs(dict(zip(*(lambda m: (m.name, m.position))(states.fresh())))["left_hand_Pinky"] - 0.5) < 0.01,
            30,
            "the left pinky at 0.5",
        )
    finally:
        stop(node)


def test_generated_message_md5sums_equal_noetic() -> None:
    """md5sums a Noetic system checks: SwitchController's as a Noetic client asked for it
    (h4r_ev3_ctrl#22), JointTrajectoryControllerState's as control_msgs 1.5 has it; genmsg's md5 text
    rebuilt here agrees with genpy's own hash of FollowJointTrajectoryGoal."""
    import hashlib

    from svhdesc.ros1.messages import _own_definitions, control_msgs, controller_manager_msgs, md5_text

    msgs, manager = control_msgs(), controller_manager_msgs()
    assert manager.SwitchController._md5sum == "b29a7abc673b2c54c14b54e50f8d06a5"
    assert manager.SwitchController._type == "controller_manager_msgs/SwitchController"
    assert msgs.JointTrajectoryControllerState._md5sum == "10817c60c2486ef6b33e97dcd87f4474"
    assert manager.ListControllers._md5sum == "1341feb2e63fa791f855565d0da950d8"
    assert manager.ListControllerTypes._md5sum == "c1d4cd11aefa9f97ba4aeb5b33987f4e"
    assert msgs.QueryTrajectoryState._md5sum == "ec93cdecbd8062d761aa52b7c90cd44b"
    goal = _own_definitions()["FollowJointTrajectoryGoal"]

    def md5_of(full: str) -> str:
        if full.startswith("control_msgs/"):
            return getattr(msgs, full.split("/")[1])._md5sum
        package, name = full.split("/")
        import importlib

        return getattr(importlib.import_module(f"{package}.msg"), name)._md5sum

    text = md5_text(goal, "control_msgs", md5_of)
    assert hashlib.md5(text.encode()).hexdigest() == msgs.FollowJointTrajectoryGoal._md5sum


def test_hand_defaults_are_schunks_and_arm_defaults_are_urs(ros: dict[str, Any]) -> None:
    """SCHUNK's controller declares no constraints and never sees a velocity: a goal ends SUCCEEDED
    wherever the fingers stop. ur5_controllers.yaml's path tolerance (0.2 rad) aborts a goal the arm
    cannot follow."""
    from actionlib_msgs.msg import GoalStatus

    rospy, msgs = ros["rospy"], ros["msgs"]
    start = _positions(ros)["right_hand_Pinky"]
    target = 0.9 if start < 0.45 else 0.05
    results = Latest(rospy, f"/{HAND}/follow_joint_trajectory/result", msgs.FollowJointTrajectoryActionResult)
    states = Latest(rospy, f"/{HAND}/state", msgs.JointTrajectoryControllerState, keep=True)
    try:
        states.fresh()
        state, result = _send(ros, HAND, _goal(ros, ["right_hand_Pinky"], [[target]], [0.05]))
        assert state == GoalStatus.SUCCEEDED and result.error_code == 0
        ended = wait_for(lambda: results.message, 10, "the result message").header.stamp.to_sec()
        wait_for(lambda: states.all[-1].header.stamp.to_sec() > ended, 10, "a state after the result")
        at_end = min(states.all, key=lambda m: abs(m.header.stamp.to_sec() - ended))
        pinky = at_end.actual.positions[list(at_end.joint_names).index("right_hand_Pinky")]
        assert abs(pinky - target) > 0.05, (pinky, target)  # far from the goal when it succeeded
    finally:
        results.subscriber.unregister()
        states.subscriber.unregister()
    arm = [f"{n}_joint" for n in ("shoulder_pan", "shoulder_lift", "elbow", "wrist_1", "wrist_2", "wrist_3")]
    positions = _positions(ros)
    fast = [positions[arm[0]] + 1.0, *[positions[j] for j in arm[1:]]]
    state, result = _send(ros, ARM, _goal(ros, arm, [fast], [0.1]))
    assert state == GoalStatus.ABORTED
    assert result.error_code == ros["msgs"].FollowJointTrajectoryResult.PATH_TOLERANCE_VIOLATED
    back = [positions[j] for j in arm]
    state, _ = _send(ros, ARM, _goal(ros, arm, [back], [2.0]))
    assert state == GoalStatus.SUCCEEDED


def test_controller_state_topic_and_query_state(ros: dict[str, Any]) -> None:
    from actionlib_msgs.msg import GoalStatus

    rospy, msgs = ros["rospy"], ros["msgs"]
    state = Latest(rospy, f"/{HAND}/state", msgs.JointTrajectoryControllerState, keep=True)
    try:
        first = state.fresh(20)
        wait_for(lambda: len(state.all) >= 6, 20, "a few states")
        assert len(first.joint_names) == 9 and first.joint_names[0] == "right_hand_Thumb_Flexion"
        stamps = [m.header.stamp.to_sec() for m in state.all[-5:]]
        # Exactly 50 Hz of simulated time (the rate rule itself: tests/control/test_trajectory_core.py).
        assert np.median(np.diff(stamps)) == pytest.approx(0.02, abs=1e-6)
        # The arm's at ur_robot_driver's 125 Hz: the node steps to every 8 ms instant (seeded fault: the arm's
        # controller updated only on the 10 ms /clock grid, as before, gave 0.01).
        arm_state = Latest(rospy, f"/{ARM}/state", msgs.JointTrajectoryControllerState, keep=True)
        try:
            arm_state.fresh(20)
            wait_for(lambda: len(arm_state.all) >= 6, 20, "a few arm states")
            arm_stamps = [m.header.stamp.to_sec() for m in arm_state.all[-5:]]
            assert np.median(np.diff(arm_stamps)) == pytest.approx(0.008, abs=1e-6)
        finally:
            arm_state.subscriber.unregister()
        # Compared at rest: a finger still on its way from an earlier goal moves between the two messages.
        positions = _at_rest(ros, list(first.joint_names))
        latest = state.fresh()
        for name, actual in zip(latest.joint_names, latest.actual.positions):
            assert actual == pytest.approx(positions[name], abs=5e-3), name
    finally:
        state.subscriber.unregister()
    query = rospy.ServiceProxy(f"/{HAND}/query_state", msgs.QueryTrajectoryState)
    query.wait_for_service(20)
    client = _client(ros, HAND)
    now = rospy.Time.now()
    # Long enough (simulated time) to be still active when queried however slowly this machine runs the node:
    # a finished goal is replaced by a hold, whose samples are the hand's position.
    goal = _goal(ros, ["right_hand_Ring_Finger"], [[0.2], [0.6]], [100.0, 200.0])
    goal.trajectory.header.stamp = now
    client.send_goal(goal)
    wait_for(lambda: client.get_state() == GoalStatus.ACTIVE, 30, "the goal to start")
    answer = query(now + rospy.Duration(250.0))  # after the end: the last point
    ring = list(answer.name).index("right_hand_Ring_Finger")
    assert answer.position[ring] == pytest.approx(0.6, abs=1e-6) and answer.velocity[ring] == 0.0
    middle = query(now + rospy.Duration(100.0))
    assert middle.position[ring] == pytest.approx(0.2, abs=1e-6)
    assert client.get_state() == GoalStatus.ACTIVE  # both answers came from this goal, not a hold after it
    client.cancel_goal()
    assert client.wait_for_result(rospy.Duration(60)) and client.get_state() == GoalStatus.PREEMPTED


def test_controller_manager_lists_and_switches_like_ur_robot_driver(ros: dict[str, Any]) -> None:
    from actionlib_msgs.msg import GoalStatus

    from svhdesc.ros1.messages import controller_manager_msgs

    rospy, cm = ros["rospy"], controller_manager_msgs()
    listing = rospy.ServiceProxy("/controller_manager/list_controllers", cm.ListControllers)
    switch = rospy.ServiceProxy("/controller_manager/switch_controller", cm.SwitchController)
    types = rospy.ServiceProxy("/controller_manager/list_controller_types", cm.ListControllerTypes)
    listing.wait_for_service(20)

    def states() -> dict[str, str]:
        return {c.name: c.state for c in listing().controller}

    assert states() == {
        "joint_state_controller": "running",
        HAND: "running",
        ARM: "running",
        "pos_joint_traj_controller": "initialized",
        "joint_group_vel_controller": "initialized",
        "forward_position_controller": "initialized",
        HAND_FORWARD: "initialized",
    }
    claimed = {c.name: c.claimed_resources[0].resources for c in listing().controller}
    assert len(claimed[ARM]) == 6 and claimed[ARM] == claimed["pos_joint_traj_controller"]
    assert "position_controllers/ScaledJointTrajectoryController" in types().types
    strict, best = cm.SwitchControllerRequest.STRICT, cm.SwitchControllerRequest.BEST_EFFORT
    # Both arm controllers would claim the same joints: refused, whatever the strictness.
    assert not switch(["pos_joint_traj_controller"], [], best, False, 0.0).ok
    assert not switch(["pos_joint_traj_controller"], ["no_such_controller"], strict, False, 0.0).ok
    assert states()[ARM] == "running"
    # ros_control 0.20 refuses starting and stopping one controller in one request (seeded fault: the
    # former manager answered ok).
    assert not switch([ARM], [ARM], best, False, 0.0).ok and states()[ARM] == "running"
    assert switch(["pos_joint_traj_controller"], [ARM, "no_such_controller"], best, False, 0.0).ok
    try:
        assert states()[ARM] == "stopped" and states()["pos_joint_traj_controller"] == "running"
        arm = claimed[ARM]
        here = _positions(ros)
        goal = _goal(ros, arm, [[here[j] for j in arm]], [0.5])
        state, result = _send(ros, ARM, goal)  # a stopped JTC rejects every goal with INVALID_GOAL
        assert state == GoalStatus.REJECTED
        assert result.error_code == ros["msgs"].FollowJointTrajectoryResult.INVALID_GOAL
        moved = [here[arm[0]] + 0.1, *[here[j] for j in arm[1:]]]
        state, _ = _send(ros, "pos_joint_traj_controller", _goal(ros, arm, [moved], [1.0]))
        assert state == GoalStatus.SUCCEEDED
        assert _positions(ros)[arm[0]] == pytest.approx(moved[0], abs=0.02)
    finally:
        assert switch([ARM], ["pos_joint_traj_controller"], strict, False, 0.0).ok
    assert states()[ARM] == "running"
    # The velocity group controller: switched on, its command moves the joints at that speed. Everything is
    # judged on the node's simulated time (the joint states' stamps), never on this client's clock, which lags.
    from rosgraph_msgs.msg import Log
    from sensor_msgs.msg import JointState
    from std_msgs.msg import Float64MultiArray

    command = rospy.Publisher("/joint_group_vel_controller/command", Float64MultiArray, queue_size=1)
    wait_for(lambda: command.get_num_connections(), 20, "the velocity command subscriber")
    log = Latest(rospy, "/rosout", Log, keep=True)
    assert switch(["joint_group_vel_controller"], [ARM], strict, False, 0.0).ok
    try:
        before = _at_rest(ros, arm)[arm[0]]

        def refused() -> bool:  # published until the node says it ignored it: it surely arrived
            command.publish(Float64MultiArray(data=[0.5]))  # wrong size
            return any("command: 1 values" in m.msg and m.name.endswith("svhdesc_sim") for m in log.all)

        wait_for(refused, 60, "the wrong-size command's refusal", period=0.2)
        assert abs(_positions(ros)[arm[0]] - before) < 2e-3
        track = Latest(rospy, "/joint_states", JointState, keep=True)
        command.publish(Float64MultiArray(data=[0.2, 0, 0, 0, 0, 0]))
        wait_for(lambda: _positions(ros)[arm[0]] - before > 0.3, 120, "the arm to turn 0.3 rad")
        command.publish(Float64MultiArray(data=[0.0] * 6))
        stopped = _at_rest(ros, arm)[arm[0]]  # and the zero command stops it
        track.subscriber.unregister()
        samples = [(m.header.stamp.to_sec(), m.position[list(m.name).index(arm[0])]) for m in track.all]
        # The steady part of the motion, past the servo's start and before the stop command went out.
        steady = np.array([(t, q) for t, q in samples if before + 0.1 < q < before + 0.28])
        assert len(steady) > 10, samples
        speed = np.polyfit(steady[:, 0], steady[:, 1], 1)[0]
        assert speed == pytest.approx(0.2, abs=0.01), speed
        assert stopped - before > 0.3
    finally:
        log.subscriber.unregister()
        assert switch([ARM], ["joint_group_vel_controller"], strict, False, 0.0).ok
    assert states()["joint_group_vel_controller"] == "stopped"


def test_forward_position_controllers_like_ros_controllers(ros: dict[str, Any]) -> None:
    """The position groups (ros_controllers' position_controllers/JointGroupPositionController on the control core's
    NOETIC_FORWARD), loaded stopped: starting one beside the running trajectory controller of its joints is refused
    (a resource claimed twice); swapped in (STRICT), its command (one position per channel, in the driver's order)
    moves the hand there; a command one value short is refused with the real controller's error ("Dimension of
    command (8) does not match number of joints (9)! Not executing!") and the controller runs on, the hand where it
    was. Seeded faults: the adapter reversing the command -> the hand never reaches it; NOETIC_FORWARD's
    wrong_size_fails True -> Jazzy's error text, the refusal not found."""
    from rosgraph_msgs.msg import Log
    from std_msgs.msg import Float64MultiArray

    from svhdesc.ros1.messages import controller_manager_msgs

    rospy, cm = ros["rospy"], controller_manager_msgs()
    listing = rospy.ServiceProxy("/controller_manager/list_controllers", cm.ListControllers)
    switch = rospy.ServiceProxy("/controller_manager/switch_controller", cm.SwitchController)
    listing.wait_for_service(20)
    strict = cm.SwitchControllerRequest.STRICT

    def listed() -> dict[str, Any]:
        return {c.name: c for c in listing().controller}

    assert listed()[HAND_FORWARD].type == "position_controllers/JointGroupPositionController"
    channels = [f"right_hand_{c}" for c in DRIVER_CHANNELS]
    assert listed()[HAND_FORWARD].claimed_resources[0].resources == channels
    assert not switch([HAND_FORWARD], [], strict, False, 0.0).ok  # HAND runs on the same joints
    command = rospy.Publisher(f"/{HAND_FORWARD}/command", Float64MultiArray, queue_size=1)
    wait_for(lambda: command.get_num_connections(), 20, "the forward command subscriber")
    log = Latest(rospy, "/rosout", Log, keep=True)
    assert switch([HAND_FORWARD], [HAND], strict, False, 0.0).ok
    try:
        assert listed()[HAND_FORWARD].state == "running" and listed()[HAND].state == "stopped"
        here = _at_rest(ros, channels)
        test = _keyframe("test")
        target = [test[j] for j in channels]
        command.publish(Float64MultiArray(data=target))
        reached = lambda: all(abs(_positions(ros)[j] - t) < 0.02 for j, t in zip(channels, target))  # noqa: E731
        wait_for(reached, 120, "the hand at the commanded positions")
        moved = max(abs(here[j] - t) for j, t in zip(channels, target))
        assert moved > 0.1, moved

        def refused() -> bool:  # published until the node says it refused it: it surely arrived
            command.publish(Float64MultiArray(data=[0.1] * 8))
            text = "Dimension of command (8) does not match number of joints (9)! Not executing!"
            return any(text in m.msg and m.name.endswith("svhdesc_sim") for m in log.all)

        wait_for(refused, 60, "the short command's refusal", period=0.2)
        assert listed()[HAND_FORWARD].state == "running"
        held = _at_rest(ros, channels)
        assert max(abs(held[j] - t) for j, t in zip(channels, target)) < 0.02
    finally:
        log.subscriber.unregister()
        command.unregister()
        assert switch([HAND], [HAND_FORWARD], strict, False, 0.0).ok
    assert listed()[HAND].state == "running" and listed()[HAND_FORWARD].state == "stopped"


def test_a_velocity_servo_gets_velocity_controllers_group(ros: dict[str, Any]) -> None:
    """A continuous joint on a velocity servo (joints.NAME.servo: velocity, tests/support.py ``wheeled``): the node
    runs velocity_controllers/JointGroupVelocityController ``forward_velocity_controller`` over it (running, its
    VelocityJointInterface), the trajectory and position controllers leave it out; a command turns the wheel at that
    velocity, and zero stops it. Seeded faults: RobotInfo keeping the wheel in arm_joints -> the trajectory controller
    claims it; the group loaded with its core stopped -> the wheel never turns."""
    from sensor_msgs.msg import JointState
    from std_msgs.msg import Float64MultiArray

    from svhdesc.ros1.messages import controller_manager_msgs
    from tests.support import wheeled

    rospy, cm = ros["rospy"], controller_manager_msgs()
    folder = wheeled()
    node = subprocess.Popen(
        [svhdesc_executable(), "sim", str(folder), "--ros", "--realtime", "--duration", "600"]
        + ["__ns:=/wheeled", "__name:=wheeled_sim", "/clock:=/wheeled/clock"],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    try:
        states = Latest(rospy, "/wheeled/joint_states", JointState)
        wait_for(lambda: states.message, 60, "/wheeled/joint_states")
        listing = rospy.ServiceProxy("/wheeled/controller_manager/list_controllers", cm.ListControllers)
        listing.wait_for_service(30)
        listed = {c.name: c for c in listing().controller}
        velocity = listed["forward_velocity_controller"]
        assert velocity.type == "velocity_controllers/JointGroupVelocityController" and velocity.state == "running"
        assert velocity.claimed_resources[0].resources == ["wheel"]
        assert velocity.claimed_resources[0].hardware_interface == "hardware_interface::VelocityJointInterface"
        assert all("wheel" not in c.claimed_resources[0].resources for n, c in listed.items() if c is not velocity)

        def speed() -> float:
            message = states.fresh()
            return dict(zip(message.name, message.velocity))["wheel"]

        assert abs(speed()) < 1e-3  # held still from the start
        command = rospy.Publisher("/wheeled/forward_velocity_controller/command", Float64MultiArray, queue_size=1)
        wait_for(lambda: command.get_num_connections(), 20, "the velocity command subscriber")
        for target in (1.5, -0.5, 0.0):
            command.publish(Float64MultiArray(data=[target]))
            wait_for(lambda t=target: abs(speed() - t) < 0.02, 60, f"the wheel at {target} rad/s", period=0.2)
        command.unregister()
    finally:
        stop(node)
