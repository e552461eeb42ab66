"""An independent ROS 2 client of ``svhdesc sim VARIANT --ros2``: rclpy, control_msgs and controller_manager_msgs
only; it imports nothing of svhdesc and knows the node only by the ROS 2 names (from the variant's generated ROS 2
files: ros2/config/ros2_controllers.yaml and ros2/mujoco/<variant>.xml).

    python client.py VARIANT_DIR REPORT.json        # every check, one JSON report (tests/ros2/test_node.py reads it)
    python client.py --die VARIANT_DIR CONTROLLER   # send a long goal, print "accepted", kill itself (SIGKILL)
    python client.py --recording FILE.mcap OUT.json # read the node's recording back with rosbags
    python client.py --tracker VARIANT_DIR OUT.json BODY...   # tracked/<body> poses, the forward controller driving
    python client.py --burst VARIANT_DIR OUT.json COUNT DEPTH  # COUNT goals at once, client services of DEPTH
    python client.py --velocity OUT.json JOINT     # forward_velocity_controller's listing, and JOINT's speeds

Runs inside the test's private network namespace with ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST. Every wait is on
simulated time (/clock) or on an answer, bounded by a generous wall-clock timeout.
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import threading
import time
import xml.etree.ElementTree as ET
from collections.abc import Callable
from pathlib import Path
from typing import Any

import rclpy
import yaml
from action_msgs.msg import GoalStatus
from builtin_interfaces.msg import Duration, Time
from control_msgs.action import FollowJointTrajectory
from control_msgs.msg import JointTolerance, JointTrajectoryControllerState
from controller_manager_msgs.srv import ListControllers, SwitchController
from geometry_msgs.msg import PoseStamped
from rclpy.action import ActionClient
from rclpy.executors import SingleThreadedExecutor
from rclpy.parameter import Parameter
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64MultiArray
from trajectory_msgs.msg import JointTrajectoryPoint

WALL = float(os.environ.get("SVHDESC_CLIENT_WALL", "60"))  # the most one answer may take (wall-clock s)
ARM = "scaled_joint_trajectory_controller"
FORWARD = "position_controllers/JointGroupPositionController"
STATUS = {
    GoalStatus.STATUS_SUCCEEDED: "succeeded",
    GoalStatus.STATUS_CANCELED: "canceled",
    GoalStatus.STATUS_ABORTED: "aborted",
}


def duration(seconds: float) -> Duration:
    return Duration(sec=int(seconds), nanosec=int(round((seconds - int(seconds)) * 1e9)))


def seconds(stamp: Any) -> float:
    return stamp.sec + 1e-9 * stamp.nanosec


def time_of(at: float) -> Time:
    whole, nanoseconds = divmod(int(round(at * 1e9)), 1_000_000_000)
    return Time(sec=whole, nanosec=nanoseconds)


def wait(future: Any, timeout: float = WALL) -> Any:
    done = threading.Event()
    future.add_done_callback(lambda _: done.set())
    if not done.wait(timeout):
        raise TimeoutError("no answer")
    return future.result()


class Client:
    def __init__(self, variant_dir: Path) -> None:
        self.variant = variant_dir.name
        controllers = yaml.safe_load((variant_dir / "ros2/config/ros2_controllers.yaml").read_text())
        manager = controllers["controller_manager"]["ros__parameters"]
        self.rate = float(manager["update_rate"])
        self.trajectory = {
            n: controllers[n]["ros__parameters"]["joints"]
            for n, v in manager.items()
            if isinstance(v, dict) and n in controllers and v["type"] != FORWARD
        }
        self.forward = {
            n: controllers[n]["ros__parameters"]["joints"]
            for n, v in manager.items()
            if isinstance(v, dict) and v["type"] == FORWARD
        }
        self.hand = next(n for n in self.trajectory if n != ARM)
        mjcf = ET.parse(variant_dir / "ros2/mujoco" / f"{self.variant}.xml")
        self.ranges = {
            j.get("name"): tuple(map(float, j.get("range", "0 0").split())) for j in mjcf.iter("joint") if j.get("name")
        }
        # joint_state_broadcaster publishes every joint of the ros2_control system
        system = ET.parse(variant_dir / "ros2/urdf" / f"{self.variant}.ros2_control.xacro")
        self.system_joints = sorted(j.get("name") for r in system.iter("ros2_control") for j in r.iter("joint"))
        self.node = rclpy.create_node(
            "svhdesc_test_client", parameter_overrides=[Parameter("use_sim_time", Parameter.Type.BOOL, True)]
        )
        self.states: list[JointState] = []
        self.clocks: list[float] = []
        self.controller_states: dict[str, JointTrajectoryControllerState] = {}
        self._lock = threading.Lock()
        self.node.create_subscription(JointState, "/joint_states", self._on_state, 100)
        self.node.create_subscription(Clock, "/clock", self._on_clock, 100)
        self.actions = {
            n: ActionClient(self.node, FollowJointTrajectory, f"/{n}/follow_joint_trajectory") for n in self.trajectory
        }
        self.list = self.node.create_client(ListControllers, "/controller_manager/list_controllers")
        self.switch = self.node.create_client(SwitchController, "/controller_manager/switch_controller")
        self.executor = SingleThreadedExecutor()
        self.executor.add_node(self.node)
        threading.Thread(target=self.executor.spin, daemon=True).start()

    # -- plumbing ------------------------------------------------------------------------------
    def _on_state(self, message: JointState) -> None:
        with self._lock:
            self.states.append(message)
            del self.states[:-2000]

    def _on_clock(self, message: Clock) -> None:
        with self._lock:
            self.clocks.append(message.clock.sec + 1e-9 * message.clock.nanosec)
            del self.clocks[:-5000]

    def now(self) -> float:
        deadline = time.monotonic() + WALL
        while not self.clocks:
            if time.monotonic() > deadline:
                raise TimeoutError("no /clock")
            time.sleep(0.01)
        return self.clocks[-1]

    def sleep(self, seconds: float) -> None:
        """Wait ``seconds`` of simulated time."""
        until, deadline = self.now() + seconds, time.monotonic() + WALL
        while self.now() < until:
            if time.monotonic() > deadline:
                raise TimeoutError("the simulation stopped")
            time.sleep(0.005)

    def latest(self) -> float:
        """The stamp of the newest /joint_states this client has seen (simulated seconds)."""
        self.now()
        while not self.states:
            time.sleep(0.01)
        return seconds(self.states[-1].header.stamp)

    def at(self, when: float) -> dict[str, float]:
        """The joints as the first /joint_states stamped at or after ``when`` report them: exact simulated instants,
        however far this client's callbacks lag behind the node on a busy machine."""
        deadline = time.monotonic() + WALL
        while self.latest() < when - 1e-6:
            if time.monotonic() > deadline:
                raise TimeoutError(f"no /joint_states at {when}")
            time.sleep(0.005)
        with self._lock:
            found = next(m for m in self.states if seconds(m.header.stamp) >= when - 1e-6)
        return dict(zip(found.name, found.position))

    def positions(self) -> dict[str, float]:
        return self.at(self.latest())

    def ready(self) -> None:
        for client in self.actions.values():
            if not client.wait_for_server(timeout_sec=WALL):
                raise TimeoutError("no action server")
        for service in (self.list, self.switch):
            if not service.wait_for_service(timeout_sec=WALL):
                raise TimeoutError("no controller_manager service")
        self.now()

    def goal(
        self,
        names: list[str],
        points: list[tuple[float, list[float]]],
        stamp: Time | None = None,
        goal_tolerance: float = 0.0,
        path_tolerance: float = 0.0,
        goal_time: float = 0.0,
    ) -> FollowJointTrajectory.Goal:
        goal = FollowJointTrajectory.Goal()
        goal.trajectory.joint_names = list(names)
        if stamp is not None:
            goal.trajectory.header.stamp = stamp
        goal.trajectory.points = [
            JointTrajectoryPoint(positions=list(p), time_from_start=duration(t)) for t, p in points
        ]
        if goal_tolerance:
            goal.goal_tolerance = [JointTolerance(name=n, position=goal_tolerance) for n in names]
        if path_tolerance:
            goal.path_tolerance = [JointTolerance(name=n, position=path_tolerance) for n in names]
        goal.goal_time_tolerance = duration(goal_time)
        return goal

    def asked(self, request: Callable[[], Any]) -> Any:
        """The future that ``request`` (an ActionClient's ``*_async`` call) returns, called on the executor's thread.
        Jazzy's ActionClient files a request's future only after sending it; a reply that the executor takes in
        between is dropped ("Ignoring unexpected goal response") and the future never ends. Sent from the executor's
        own thread, no reply can come in between."""
        return wait(self.executor.create_task(request))

    def send(self, controller: str, goal: Any) -> Any:
        """The goal handle (accepted or not)."""
        return wait(self.asked(lambda: self.actions[controller].send_goal_async(goal)))

    def result(self, handle: Any) -> Any:
        return self.asked(handle.get_result_async)

    def run(self, controller: str, goal: Any) -> dict[str, Any]:
        handle = self.send(controller, goal)
        if not handle.accepted:
            return {"accepted": False}
        answer = wait(self.result(handle))
        return {
            "accepted": True,
            "status": STATUS.get(answer.status, answer.status),
            "code": answer.result.error_code,
            "text": answer.result.error_string,
        }

    def target(self, fraction: float, joints: list[str]) -> list[float]:
        return [self.ranges[j][0] + fraction * (self.ranges[j][1] - self.ranges[j][0]) for j in joints]

    def listed(self) -> dict[str, dict[str, Any]]:
        answer = wait(self.list.call_async(ListControllers.Request()))
        return {
            c.name: {
                "state": c.state,
                "type": c.type,
                "claimed": list(c.claimed_interfaces),
                "required": list(c.required_command_interfaces),
            }
            for c in answer.controller
        }

    def switched(self, activate: list[str], deactivate: list[str]) -> bool:
        request = SwitchController.Request(
            activate_controllers=activate, deactivate_controllers=deactivate, strictness=SwitchController.Request.STRICT
        )
        return bool(wait(self.switch.call_async(request)).ok)

    def publisher(self, topic: str, kind: Any) -> Any:
        """A publisher matched with the node's subscription (a message sent before discovery would be lost)."""
        publisher = self.node.create_publisher(kind, topic, 10)
        deadline = time.monotonic() + WALL
        while publisher.get_subscription_count() == 0:
            if time.monotonic() > deadline:
                raise TimeoutError(f"nobody subscribes {topic}")
            time.sleep(0.01)
        return publisher


# -- the checks (each returns what the test asserts on) ------------------------------------------
def joint_states(c: Client) -> dict[str, Any]:
    with c._lock:
        c.states.clear()
    c.sleep(2.0)
    with c._lock:
        window = list(c.states)
        clocks = list(c.clocks)
    stamps = [m.header.stamp.sec + 1e-9 * m.header.stamp.nanosec for m in window]
    return {
        "rate": c.rate,
        "count": len(window),
        "steps": [round(b - a, 6) for a, b in zip(stamps, stamps[1:])],
        "names": sorted(window[-1].name),
        "sizes": [len(window[-1].position), len(window[-1].velocity), len(window[-1].effort)],
        "expected": c.system_joints,
        "clock_monotonic": all(b >= a for a, b in zip(clocks, clocks[1:])),
        "clock_count": len(clocks),
    }


def controller_states(c: Client) -> dict[str, Any]:
    subscriptions = [
        c.node.create_subscription(
            JointTrajectoryControllerState,
            f"/{name}/controller_state",
            lambda m, n=name: c.controller_states.__setitem__(n, m),
            1,
        )
        for name in c.trajectory
    ]
    c.sleep(0.2)
    # A new subscription's discovery can take longer than 0.2 simulated s on a busy machine: wait for one state
    # of each controller (bounded), so a slow match is not read as a silent controller.
    deadline = time.monotonic() + WALL
    while set(c.controller_states) != set(c.trajectory) and time.monotonic() < deadline:
        time.sleep(0.01)
    for subscription in subscriptions:
        c.node.destroy_subscription(subscription)
    return {
        n: {
            "joint_names": list(m.joint_names),
            "reference": len(m.reference.positions),
            "feedback": len(m.feedback.positions),
        }
        for n, m in c.controller_states.items()
    }


def goals(c: Client) -> dict[str, Any]:
    """Each goal starts at a stamp 0.5 s ahead, so that its end is known: the joints are read 0.3 s after it."""
    out: dict[str, Any] = {}
    for name, joints in c.trajectory.items():
        start = c.latest() + 0.5
        target = (
            c.target(0.3, joints)
            if name == c.hand
            else [p + d for p, d in zip([c.positions()[j] for j in joints], [0.2, -0.2, 0.2, -0.2, 0.2, 0.2])]
        )
        goal = c.goal(joints, [(1.5, target)], stamp=time_of(start), goal_tolerance=0.05, goal_time=2.0)
        result = c.run(name, goal)
        reached = c.at(start + 1.5 + 0.3)
        result["errors"] = {j: abs(reached[j] - t) for j, t in zip(joints, target)}
        out[name] = result
    home = c.run(c.hand, c.goal(c.trajectory[c.hand], [(1.0, c.target(0.0, c.trajectory[c.hand]))]))
    out["home"] = home
    return out


def malformed(c: Client) -> dict[str, bool]:
    """Each case: was it accepted? (Jazzy's JTC rejects them all in its goal callback.)"""
    joints = c.trajectory[c.hand]
    ok = c.target(0.1, joints)
    c.sleep(max(0.0, 1.5 - c.now()))  # a stale stamp needs simulated time > 1 s
    cases = {
        "unknown joint": c.goal([*joints[:-1], "no_such_joint"], [(1.0, ok)]),
        "ROS 1 joint name": c.goal([joints[0].replace("Right_Hand_", "right_hand_")], [(1.0, ok[:1])]),
        "no joint names": c.goal([], [(1.0, [])]),
        "no points": c.goal(joints, []),
        "positions size": c.goal(joints, [(1.0, ok[:-1])]),
        "times not increasing": c.goal(joints, [(1.0, ok), (1.0, ok)]),
        "stale stamp": c.goal(joints, [(1.0, ok)], stamp=Time(sec=0, nanosec=1000)),
        "position outside limits": c.goal(joints, [(1.0, [v + 10.0 for v in ok])]),
        "nan position": c.goal(joints, [(1.0, [float("nan")] * len(joints))]),
        "a channel twice": c.goal([*joints, joints[0]], [(1.0, [*ok, ok[0]])]),
    }
    found = {case: c.send(c.hand, goal).accepted for case, goal in cases.items()}
    if ARM in c.trajectory:
        arm = c.trajectory[ARM]
        here = [c.positions()[j] for j in arm]
        found["partial arm goal"] = c.send(ARM, c.goal(arm[:3], [(1.0, here[:3])])).accepted
    return found


def preempt_and_cancel(c: Client) -> dict[str, Any]:
    joints = c.trajectory[c.hand]
    first = c.send(c.hand, c.goal(joints, [(3.0, c.target(0.3, joints))]))
    first_result = c.result(first)
    c.sleep(0.3)
    second = c.run(c.hand, c.goal(joints, [(1.0, c.target(0.05, joints))]))
    ended = wait(first_result)
    target, start = c.target(0.3, joints), c.latest() + 0.5
    third = c.send(c.hand, c.goal(joints, [(3.0, target)], stamp=time_of(start)))
    c.at(start + 0.5)
    cancel = wait(c.asked(third.cancel_goal_async))
    canceled = wait(c.result(third))
    before = c.at(start + 1.5)  # uncanceled, the fingers would move on until start + 3 s
    after = c.at(start + 2.0)
    # A partial goal canceled while the joints it leaves out still close on the command they kept (issue 39): every
    # joint holds where it is, as JTC's set_hold_position. From the result's arrival on, 1.5 simulated s.
    whole = c.send(c.hand, c.goal(joints, [(2.0, c.target(0.3, joints))]))
    c.sleep(0.4)
    partial = c.send(c.hand, c.goal(joints[-2:], [(3.0, c.target(0.05, joints[-2:]))]))
    c.sleep(0.1)
    wait(c.asked(partial.cancel_goal_async))
    partial_result = wait(c.result(partial))
    wait(c.result(whole))
    # From half a simulated second after the result's arrival on (the cancel was worked at or before it; on a busy
    # machine this client's newest state lags the node, and a joint stopped mid-motion settles in a few ms): 1 s more.
    answered = c.latest()
    held, settled = c.at(answered + 0.5), c.at(answered + 1.5)
    return {
        "preempted": {
            "status": STATUS.get(ended.status, ended.status),
            "code": ended.result.error_code,
            "text": ended.result.error_string,
        },
        "preempting": second,
        "cancel_accepted": len(cancel.goals_canceling) == 1,
        "canceled": {"status": STATUS.get(canceled.status, canceled.status), "code": canceled.result.error_code},
        "moved_after_cancel": max(abs(after[j] - before[j]) for j in joints),
        "partial_canceled": STATUS.get(partial_result.status, partial_result.status),
        "drift_after_partial_cancel": {j: abs(settled[j] - held[j]) for j in joints},
        "short_of_target": max(abs(after[j] - t) for j, t in zip(joints, target)),
    }


def tolerances(c: Client) -> dict[str, Any]:
    joints = c.trajectory[c.hand]
    path = c.run(c.hand, c.goal(joints, [(0.5, c.target(0.3, joints))], path_tolerance=1e-4))
    goal = c.run(c.hand, c.goal(joints, [(0.3, c.target(0.05, joints))], goal_tolerance=1e-6, goal_time=0.02))
    return {"path": path, "goal": goal}


def burst(c: Client, count: int = 1000) -> dict[str, Any]:
    joints = c.trajectory[c.hand]
    bad = c.goal([*joints[:-1], "no_such_joint"], [(1.0, c.target(0.1, joints))])
    accepted, window = 0, 10  # at most the client services' default depth (10) in flight: DDS drops the rest
    for _ in range(count // window):
        futures = [c.asked(lambda: c.actions[c.hand].send_goal_async(bad)) for _ in range(window)]
        accepted += sum(wait(f).accepted for f in futures)
    start = c.now()
    after = c.run(c.hand, c.goal(joints, [(0.5, c.target(0.1, joints))]))
    c.sleep(0.2)
    return {"sent": count, "accepted": accepted, "after": after, "clock_advanced": c.now() > start}


def true_burst(c: Client, count: int = 300, depth: int = 1000) -> dict[str, Any]:
    """``count`` goals sent at once (every third naming an unknown joint, the others valid 0.5 s goals, each
    preempting the one before) by an ActionClient whose services keep ``depth`` samples (rclpy's default: 10); sent
    from the executor's thread in one go, so no answer is taken before the last request is out. Counts the goal
    responses and the results of the accepted goals, waiting until 5 wall s pass with nothing new."""
    from rclpy.qos import QoSProfile, qos_profile_services_default

    default = qos_profile_services_default
    qos = QoSProfile(
        history=default.history, depth=depth, reliability=default.reliability, durability=default.durability
    )
    client = ActionClient(
        c.node,
        FollowJointTrajectory,
        f"/{c.hand}/follow_joint_trajectory",
        goal_service_qos_profile=qos,
        result_service_qos_profile=qos,
        cancel_service_qos_profile=qos,
    )
    if not client.wait_for_server(timeout_sec=WALL):
        raise TimeoutError("no action server")
    joints = c.trajectory[c.hand]
    valid = c.goal(joints, [(0.5, c.target(0.1, joints))])
    bad = c.goal([*joints[:-1], "no_such_joint"], [(0.5, c.target(0.1, joints))])
    lock = threading.Lock()
    responses: list[bool] = []
    results: list[int] = []

    def on_result(future: Any) -> None:
        with lock:
            results.append(future.result().status)

    def on_response(future: Any) -> None:
        handle = future.result()
        with lock:
            responses.append(handle.accepted)
        if handle.accepted:
            handle.get_result_async().add_done_callback(on_result)

    def send() -> float:
        began = time.perf_counter()
        for k in range(count):
            client.send_goal_async(bad if k % 3 == 2 else valid).add_done_callback(on_response)
        return time.perf_counter() - began

    took = wait(c.executor.create_task(send))
    seen, quiet = (-1, -1), time.monotonic()
    while time.monotonic() - quiet < 5.0:
        time.sleep(0.2)
        with lock:
            now = (len(responses), len(results))
        if now != seen:
            seen, quiet = now, time.monotonic()
    with lock:
        return {
            "sent": count,
            "malformed": count // 3,
            "depth": depth,
            "send_seconds": round(took, 4),
            "responses": len(responses),
            "accepted": sum(responses),
            "results": len(results),
        }


def killed_client(c: Client, variant_dir: Path) -> dict[str, Any]:
    child = subprocess.Popen(
        [sys.executable, __file__, "--die", str(variant_dir), c.hand], stdout=subprocess.PIPE, text=True
    )
    line = child.stdout.readline().strip() if child.stdout else ""
    child.wait(WALL)
    c.sleep(0.3)
    joints = c.trajectory[c.hand]
    after = c.run(c.hand, c.goal(joints, [(0.5, c.target(0.0, joints))]))
    return {"child": line, "returncode": child.returncode, "after": after}


def switching(c: Client) -> dict[str, Any]:
    joints = c.trajectory[c.hand]
    before = c.listed()
    off = c.switched([], [c.hand])
    listed_off = c.listed()[c.hand]
    refused = c.send(c.hand, c.goal(joints, [(0.5, c.target(0.1, joints))])).accepted
    on = c.switched([c.hand], [])
    both = c.switched([c.hand], [c.hand])
    restarted = c.listed()[c.hand]
    unknown = c.switched(["no_such_controller"], [])
    return {
        "before": before,
        "deactivated": off,
        "listed_inactive": listed_off,
        "goal_accepted_while_inactive": refused,
        "activated": on,
        "listed_after": c.listed()[c.hand],
        "start_and_stop_at_once": both,
        "listed_restarted": restarted,
        "unknown_strict": unknown,
    }


def forward(c: Client) -> dict[str, Any]:
    """The forward position controllers: listed inactive; activating one beside the active trajectory controller of
    its joints (a claimed interface); swapping them; commands in the yaml's joint order; a command of the wrong
    length (the controller is deactivated), non-finite values (dropped); swapping back (a goal succeeds)."""
    out: dict[str, Any] = {"listed": {n: c.listed()[n] for n in c.forward}}
    for name, joints in c.forward.items():
        trajectory = next(t for t, j in c.trajectory.items() if set(j) == set(joints))
        part: dict[str, Any] = {"trajectory": trajectory}
        part["beside_ok"] = c.switched([name], [])  # Jazzy answers ok; the activation fails on the conflict
        part["beside_state"] = c.listed()[name]["state"]
        part["swapped"] = c.switched([name], [trajectory])
        listed = c.listed()
        part["after_swap"] = {"forward": listed[name], "trajectory": listed[trajectory]["state"]}
        part["goal_accepted"] = c.send(trajectory, c.goal(joints, [(0.5, c.target(0.1, joints))])).accepted
        commands = c.publisher(f"/{name}/commands", Float64MultiArray)
        here = c.positions()
        target = (
            c.target(0.4, joints) if trajectory == c.hand else [here[j] + d for j, d in zip(joints, (0.15, -0.15) * 3)]
        )
        sent = c.latest()
        _repeat(c, commands, Float64MultiArray(data=target), 0.5)
        reached = c.at(sent + 2.0)
        part["errors"] = {j: abs(reached[j] - t) for j, t in zip(joints, target)}
        commands.publish(Float64MultiArray(data=[float("nan")] * len(joints)))
        c.sleep(0.3)
        part["after_nan"] = {"state": c.listed()[name]["state"], "moved": _moved(reached, c.positions(), joints)}
        commands.publish(Float64MultiArray(data=c.target(0.1, joints)[:-1]))
        c.sleep(0.3)
        before = c.positions()
        part["after_short"] = c.listed()[name]["state"]
        commands.publish(Float64MultiArray(data=c.target(0.1, joints)))  # ignored: the controller is inactive
        c.sleep(0.5)
        part["moved_while_inactive"] = _moved(before, c.positions(), joints)
        part["swapped_back"] = c.switched([trajectory], [])  # the failed controller is inactive already
        part["goal_after"] = c.run(trajectory, c.goal(joints, [(1.0, _within(c, joints, reached))]))
        c.node.destroy_publisher(commands)
        out[name] = part
    return out


def _repeat(c: Client, publisher: Any, message: Any, seconds: float) -> None:
    """``message`` sent every 0.1 simulated s for ``seconds``: the publisher sees the node's subscription before the
    subscription has matched the publisher, and a message sent in between is lost (a forward command is idempotent)."""
    until = c.now() + seconds
    while c.now() < until:
        publisher.publish(message)
        c.sleep(0.1)


def _moved(before: dict[str, float], after: dict[str, float], joints: list[str]) -> float:
    return max(abs(after[j] - before[j]) for j in joints)


def _within(c: Client, joints: list[str], positions: dict[str, float]) -> list[float]:
    """``positions`` of ``joints`` kept inside their ranges (a goal outside them is refused)."""
    return [min(max(positions[j], c.ranges[j][0]), c.ranges[j][1]) for j in joints]


def tracker(c: Client, bodies: list[str]) -> dict[str, Any]:
    """What ``tracked/<body>`` (geometry_msgs/PoseStamped) carries for each body over 2 simulated s, while the hand's
    forward position controller, swapped in, brings the channels to 30 % of their ranges."""
    poses: dict[str, list[Any]] = {b: [] for b in bodies}
    subscriptions = [
        c.node.create_subscription(PoseStamped, f"/tracked/{b}", lambda m, b=b: poses[b].append(m), 1000)
        for b in bodies
    ]
    name = next(iter(c.forward))
    joints = c.forward[name]
    swapped = c.switched([name], [c.hand])
    commands = c.publisher(f"/{name}/commands", Float64MultiArray)
    target = c.target(0.3, joints)
    start = c.latest()
    _repeat(c, commands, Float64MultiArray(data=target), 0.5)
    reached = c.at(start + 2.0)
    for subscription in subscriptions:
        c.node.destroy_subscription(subscription)
    out: dict[str, Any] = {"swapped": swapped, "errors": [abs(reached[j] - t) for j, t in zip(joints, target)]}
    for body, messages in poses.items():
        stamps = [seconds(m.header.stamp) for m in messages]
        last = messages[-1] if messages else None
        out[body] = {
            "count": len(messages),
            "frames": sorted({m.header.frame_id for m in messages}),
            "steps": sorted({round(b - a, 6) for a, b in zip(stamps, stamps[1:])}),
            "position": [last.pose.position.x, last.pose.position.y, last.pose.position.z] if last else None,
            "orientation": [
                last.pose.orientation.w,
                last.pose.orientation.x,
                last.pose.orientation.y,
                last.pose.orientation.z,
            ]
            if last
            else None,
        }
    return out


def velocity(joint: str) -> dict[str, Any]:
    """``forward_velocity_controller`` as /controller_manager lists it, and ``joint``'s speed in /joint_states 1
    simulated s after each command on its ``~/commands`` (still before the first)."""
    node = rclpy.create_node(
        "svhdesc_velocity_client", parameter_overrides=[Parameter("use_sim_time", Parameter.Type.BOOL, True)]
    )
    speeds: list[tuple[float, float]] = []
    node.create_subscription(
        JointState,
        "/joint_states",
        lambda m: speeds.append((seconds(m.header.stamp), dict(zip(m.name, m.velocity))[joint])),
        100,
    )
    listing = node.create_client(ListControllers, "/controller_manager/list_controllers")
    executor = SingleThreadedExecutor()
    executor.add_node(node)
    threading.Thread(target=executor.spin, daemon=True).start()
    if not listing.wait_for_service(timeout_sec=WALL):
        raise TimeoutError("no controller_manager service")
    found = {c.name: c for c in wait(listing.call_async(ListControllers.Request())).controller}
    controllers = {
        name: {"type": c.type, "state": c.state, "claimed": list(c.claimed_interfaces)} for name, c in found.items()
    }
    publisher = node.create_publisher(Float64MultiArray, "/forward_velocity_controller/commands", 10)

    def after(wait_s: float) -> float:
        deadline = time.monotonic() + WALL
        while not speeds:
            if time.monotonic() > deadline:
                raise TimeoutError("no /joint_states")
            time.sleep(0.01)
        until = speeds[-1][0] + wait_s
        while speeds[-1][0] < until:
            if time.monotonic() > deadline:
                raise TimeoutError("the simulation stopped")
            publisher.publish(message)  # until the node's subscription has matched: a command is idempotent
            time.sleep(0.01)
        return speeds[-1][1]

    message = Float64MultiArray(data=[0.0])
    reached = {"still": after(0.5)}
    for target in (1.5, -0.5, 0.0):
        message = Float64MultiArray(data=[target])
        reached[str(target)] = after(1.0)
    return {"controllers": controllers, "speeds": reached}


def die(variant_dir: Path, controller: str) -> None:
    c = Client(variant_dir)
    c.ready()
    joints = c.trajectory[controller]
    handle = c.send(controller, c.goal(joints, [(5.0, c.target(0.3, joints))]))
    print("accepted" if handle.accepted else "rejected", flush=True)
    c.sleep(0.2)
    os.kill(os.getpid(), signal.SIGKILL)


def read_recording(path: Path) -> dict[str, Any]:
    """What rosbags (an MCAP reader of its own, not rclpy) finds in the node's recording."""
    from rosbags.highlevel import AnyReader

    topics: dict[str, dict[str, Any]] = {}
    with AnyReader([path]) as reader:
        for connection, at, raw in reader.messages():
            message = reader.deserialize(raw, connection.msgtype)
            topic = topics.setdefault(connection.topic, {"type": connection.msgtype, "count": 0, "times": []})
            topic["count"] += 1
            topic["times"].append(at)
            if connection.topic == "/joint_states":
                topic["names"] = sorted(message.name)
                stamp = message.header.stamp.sec * 1_000_000_000 + message.header.stamp.nanosec
                topic["stamp_is_log_time"] = topic.get("stamp_is_log_time", True) and stamp == at
            if connection.msgtype.endswith("JointTrajectoryControllerState"):
                topic["joint_names"] = list(message.joint_names)
    for topic in topics.values():
        times = topic.pop("times")
        topic["increasing"] = all(b > a for a, b in zip(times, times[1:]))
        topic["steps_ns"] = sorted({b - a for a, b in zip(times, times[1:])})
    return topics


def main() -> None:
    if sys.argv[1] == "--recording":
        Path(sys.argv[3]).write_text(json.dumps(read_recording(Path(sys.argv[2])), indent=1, sort_keys=True))
        return
    rclpy.init(args=["client"])
    if sys.argv[1] == "--die":
        die(Path(sys.argv[2]), sys.argv[3])
        return
    if sys.argv[1] == "--burst":  # --burst VARIANT_DIR REPORT.json COUNT DEPTH (the action server alone is needed)
        c = Client(Path(sys.argv[2]))
        Path(sys.argv[3]).write_text(json.dumps(true_burst(c, int(sys.argv[4]), int(sys.argv[5]))))
        sys.stdout.flush()
        os._exit(0)
    if sys.argv[1] == "--velocity":  # --velocity REPORT.json JOINT
        Path(sys.argv[2]).write_text(json.dumps(velocity(sys.argv[3]), indent=1, sort_keys=True))
        sys.stdout.flush()
        os._exit(0)
    if sys.argv[1] == "--tracker":  # --tracker VARIANT_DIR REPORT.json BODY...
        c = Client(Path(sys.argv[2]))
        c.ready()
        Path(sys.argv[3]).write_text(json.dumps(tracker(c, sys.argv[4:]), indent=1, sort_keys=True))
        sys.stdout.flush()
        os._exit(0)
    variant_dir, out = Path(sys.argv[1]), Path(sys.argv[2])
    c = Client(variant_dir)
    c.ready()
    report: dict[str, Any] = {
        "variant": c.variant,
        "hand": c.hand,
        "controllers": sorted(c.trajectory),
        "forward_controllers": sorted(c.forward),
    }
    checks = [
        ("joint_states", lambda: joint_states(c)),
        ("controller_states", lambda: controller_states(c)),
        ("goals", lambda: goals(c)),
        ("malformed", lambda: malformed(c)),
        ("preempt_and_cancel", lambda: preempt_and_cancel(c)),
        ("tolerances", lambda: tolerances(c)),
        ("burst", lambda: burst(c)),
        ("true_burst", lambda: true_burst(c)),
        ("killed_client", lambda: killed_client(c, variant_dir)),
        ("switching", lambda: switching(c)),
        ("forward", lambda: forward(c)),
    ]
    for name, check in checks:
        began = time.monotonic()
        try:
            report[name] = check()
        except Exception as exc:  # noqa: BLE001 - the report says which check broke and why
            report[name] = {"error": f"{type(exc).__name__}: {exc}"}
        report.setdefault("wall", {})[name] = round(time.monotonic() - began, 2)
    out.write_text(json.dumps(report, indent=1, sort_keys=True))
    c.executor.shutdown(timeout_sec=5.0)
    c.node.destroy_node()
    rclpy.try_shutdown()
    sys.stdout.flush()
    # Python's exit then aborts in a DDS thread's destructor ("terminate called without an active exception");
    # the report is written, so leave at once.
    os._exit(0)


if __name__ == "__main__":
    main()
