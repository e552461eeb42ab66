"""A client written as for SCHUNK's ROS 2 driver (schunk_svh_ros_driver, Jazzy) and ros2_control, run against
``svhdesc sim VARIANT --ros2``: rclpy and the message packages only, nothing of svhdesc (nor of tests/ros2/client.py).
It knows the node only by what SCHUNK's doc/ros2_interfaces.md, scripts/example.py and
schunk_svh_tests/integration_tests/test_startup.py use, and by the variant's generated ROS 2 files.

    python driver_client.py VARIANT_DIR REPORT.json NODE_PID CHECK...   # the named checks, one JSON report

Each check returns plain values the test (tests/ros2/test_driver_interfaces.py) asserts on. Every wait is bounded by
a wall-clock timeout; simulated time is read from /clock.
"""

from __future__ import annotations

import json
import math
import os
import sys
import threading
import time
import xml.etree.ElementTree as ET
from collections.abc import Callable
from pathlib import Path
from typing import Any

import rclpy
import yaml
from client import duration, seconds, wait  # tests/ros2/client.py, this script's directory
from control_msgs.action import FollowJointTrajectory
from control_msgs.msg import DynamicJointState, JointTrajectoryControllerState
from control_msgs.srv import QueryTrajectoryState
from controller_manager_msgs.srv import ListControllers
from rcl_interfaces.msg import Log
from rcl_interfaces.srv import GetParameters
from rclpy.action import ActionClient
from rclpy.executors import SingleThreadedExecutor
from rclpy.qos import DurabilityPolicy, QoSProfile
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import JointState
from std_msgs.msg import Bool, String
from tf2_msgs.msg import TFMessage
from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint

WALL = 60.0  # the most one answer may take (wall-clock s)
MATCH_SETTLE = 1.0  # wall-clock s after this side matched, before the first message (see Driver.publisher)
JTC = "joint_trajectory_controller/JointTrajectoryController"
ARM = "scaled_joint_trajectory_controller"
FIST = [0.6, 0.6, 0.7, 0.7, 0.7, 0.7, 0.6, 0.6, 0.3]  # SCHUNK's scripts/example.py presets
FULL_SPREAD = [0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.5]
LATCHED = QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL)


def trajectory(names: list[str], points: list[tuple[float, list[float]]]) -> JointTrajectory:
    message = JointTrajectory(joint_names=list(names))
    for at, positions in points:
        message.points.append(JointTrajectoryPoint(positions=list(positions), time_from_start=duration(at)))
    return message


class Driver:
    """What a user of the real hand has: the graph, the topics, the services, the controllers' parameters."""

    def __init__(self, variant_dir: Path, node_pid: int) -> None:
        self.variant = variant_dir.name
        self.pid = node_pid
        config = yaml.safe_load((variant_dir / "ros2/config/ros2_controllers.yaml").read_text())
        self.config = config
        manager = config["controller_manager"]["ros__parameters"]
        self.trajectory = {n: config[n]["ros__parameters"]["joints"] for n, v in manager.items() if _is(v, JTC)}
        self.hand = next(n for n in self.trajectory if n != ARM)
        self.channels = list(self.trajectory[self.hand])  # SCHUNK's nine channels, in the driver's order
        system = ET.parse(variant_dir / "ros2/urdf" / f"{self.variant}.ros2_control.xacro")
        self.system_joints = [j.get("name") for r in system.iter("ros2_control") for j in r.iter("joint")]
        mjcf = ET.parse(variant_dir / "ros2/mujoco" / f"{self.variant}.xml")
        self.limits = {
            j.get("name"): tuple(map(float, j.get("range").split())) for j in mjcf.iter("joint") if j.get("range")
        }
        self.node = rclpy.create_node("svh_driver_user")
        self._lock = threading.Lock()
        self.joints: dict[str, float] = {}
        self.joint_names: list[str] = []
        self.clock: list[tuple[float, float]] = []  # (wall, simulated)
        self.logs: list[str] = []
        self.latched: dict[str, Any] = {}
        self.dynamic: DynamicJointState | None = None
        self.tf: dict[tuple[str, str], Any] = {}
        self.tf_static: dict[tuple[str, str], Any] = {}
        self.controller_states: dict[str, list[float]] = {}
        self.references: dict[str, dict[str, float]] = {}
        node = self.node
        node.create_subscription(JointState, "/joint_states", self._on_joints, 10)
        node.create_subscription(Clock, "/clock", self._on_clock, 10)
        node.create_subscription(Log, "/rosout", self._on_log, 1000)
        node.create_subscription(Bool, "/svh/initialized", self._keep("/svh/initialized"), LATCHED)
        node.create_subscription(String, "/robot_description", self._keep("/robot_description"), LATCHED)
        node.create_subscription(DynamicJointState, "/dynamic_joint_states", self._on_dynamic, 10)
        node.create_subscription(TFMessage, "/tf", self._on_tf(self.tf), 100)
        node.create_subscription(TFMessage, "/tf_static", self._on_tf(self.tf_static), LATCHED)
        for name in self.trajectory:
            node.create_subscription(
                JointTrajectoryControllerState, f"/{name}/controller_state", self._on_controller_state(name), 10
            )
        self.executor = SingleThreadedExecutor()
        self.executor.add_node(node)
        threading.Thread(target=self.executor.spin, daemon=True).start()

    # -- subscriptions ---------------------------------------------------------------------------
    def _on_joints(self, message: JointState) -> None:
        with self._lock:
            self.joints = dict(zip(message.name, message.position))
            self.joint_names = list(message.name)

    def _on_clock(self, message: Clock) -> None:
        with self._lock:
            self.clock.append((time.monotonic(), seconds(message.clock)))

    def _on_log(self, message: Log) -> None:
        with self._lock:
            self.logs.append(f"{message.name}: {message.msg}")

    def _keep(self, topic: str) -> Callable[[Any], None]:
        def keep(message: Any) -> None:
            self.latched[topic] = message

        return keep

    def _on_dynamic(self, message: DynamicJointState) -> None:
        self.dynamic = message

    def _on_tf(self, into: dict[tuple[str, str], Any]) -> Callable[[TFMessage], None]:
        def on(message: TFMessage) -> None:
            with self._lock:
                for t in message.transforms:
                    into[(t.header.frame_id, t.child_frame_id)] = t

        return on

    def _on_controller_state(self, name: str) -> Callable[[JointTrajectoryControllerState], None]:
        def on(message: JointTrajectoryControllerState) -> None:
            with self._lock:
                self.controller_states.setdefault(name, []).append(seconds(message.header.stamp))
                self.references[name] = dict(zip(message.joint_names, message.reference.positions))

        return on

    # -- helpers ---------------------------------------------------------------------------------
    def now(self) -> float:
        with self._lock:
            return self.clock[-1][1] if self.clock else 0.0

    def sleep(self, simulated: float) -> None:
        """Wait ``simulated`` seconds of the node's clock."""
        deadline, until = time.monotonic() + WALL, self.now() + simulated
        while self.now() < until:
            if time.monotonic() > deadline:
                raise TimeoutError("the simulated clock stopped")
            time.sleep(0.005)

    def positions(self, names: list[str]) -> list[float]:
        with self._lock:
            return [self.joints[n] for n in names]

    def ready(self) -> None:
        deadline = time.monotonic() + WALL
        while not self.joints or not self.clock:
            if time.monotonic() > deadline:
                raise TimeoutError("no joint_states or /clock")
            time.sleep(0.05)

    def publisher(self, controller: str) -> Any:
        """``/<controller>/joint_trajectory`` (depth 10, as SCHUNK's example), matched before use."""
        publisher = self.node.create_publisher(JointTrajectory, f"/{controller}/joint_trajectory", 10)
        deadline = time.monotonic() + WALL
        while publisher.get_subscription_count() == 0:
            if time.monotonic() > deadline:
                raise TimeoutError(f"nobody subscribes /{controller}/joint_trajectory")
            time.sleep(0.01)
        # Matching is not symmetric in DDS: the node's reader may match this writer a moment after this writer saw it,
        # and a volatile message sent in between is dropped (a fresh clone's run lost the first one so, under load).
        time.sleep(MATCH_SETTLE)
        return publisher

    def service(self, kind: Any, name: str, timeout: float = WALL) -> Any:
        client = self.node.create_client(kind, name)
        if not client.wait_for_service(timeout_sec=timeout):
            raise TimeoutError(f"no service {name}")
        return client

    def mid(self, joints: list[str], fraction: float) -> list[float]:
        """Positions ``fraction`` of the way from each joint's lower to its upper limit (URDF limits)."""
        return [self.limits[j][0] + fraction * (self.limits[j][1] - self.limits[j][0]) for j in joints]

    def rejected_logs(self, since: int) -> list[str]:
        with self._lock:
            return [line for line in self.logs[since:] if "joint_trajectory" in line and "rejected" in line]

    def log_count(self) -> int:
        with self._lock:
            return len(self.logs)


def _is(value: Any, kind: str) -> bool:
    return isinstance(value, dict) and value.get("type") == kind


# -- the checks ------------------------------------------------------------------------------------
def example(d: Driver) -> dict[str, Any]:
    """SCHUNK's scripts/example.py: the hand controller found by its node name, the fist and the full spread
    published on /<controller>/joint_trajectory (all nine channels, 1 s each; the sliders send one joint at a time,
    the presets here all at once); how far each channel is from each preset after it."""
    nodes = d.node.get_node_names_and_namespaces()
    found = [n for n, ns in nodes if ns == "/" and n in ("left_hand", "right_hand")]
    publisher = d.publisher(found[0] if found else d.hand)
    errors, references = {}, {}
    for name, preset in (("fist", FIST), ("full_spread", FULL_SPREAD)):
        publisher.publish(trajectory(d.channels, [(1.0, preset)]))
        d.sleep(2.5)
        errors[name] = {c: abs(a - b) for c, a, b in zip(d.channels, d.positions(d.channels), preset)}
        with d._lock:
            reference = d.references.get(d.hand, {})
        references[name] = max(abs(reference.get(c, math.inf) - b) for c, b in zip(d.channels, preset))
    return {"nodes_found": found, "errors": errors, "references": references}


def startup(d: Driver) -> dict[str, Any]:
    """SCHUNK's test_startup.py: list_controllers has the hand controller and joint_state_broadcaster active."""
    client = d.service(ListControllers, "/controller_manager/list_controllers")
    listed = wait(client.call_async(ListControllers.Request()))
    return {"states": {c.name: c.state for c in listed.controller}}


def _moved(d: Driver, joints: list[str], before: list[float]) -> float:
    return max(abs(a - b) for a, b in zip(d.positions(joints), before))


def bad_input(d: Driver) -> dict[str, Any]:
    """Each malformed trajectory on each controller's topic: rejected (a logged error), nothing moves."""
    out = {}
    for controller, joints in d.trajectory.items():
        publisher = d.publisher(controller)
        target = d.mid(joints, 0.5)
        cases = {
            "unknown_joint": trajectory([*joints[:-1], "no_such_joint"], [(0.5, target)]),
            "ros1_name": trajectory([joints[0].lower()], [(0.5, target[:1])]),
            "repeated_joint": trajectory([joints[0]] * len(joints), [(0.5, target)]),
            "missing_joints": trajectory(joints[:-1], [(0.5, target[:-1])]) if controller == ARM else None,
            "nan": trajectory(joints, [(0.5, [math.nan, *target[1:]])]),
            "times_not_increasing": trajectory(joints, [(0.5, target), (0.5, target)]),
            "time_going_back": trajectory(joints, [(0.6, target), (0.3, target)]),
            "wrong_size": trajectory(joints, [(0.5, target[:-1])]),
            "empty": JointTrajectory(joint_names=list(joints)),
            "no_joints": trajectory([], [(0.5, [])]),
            "moving_end": _with_velocity(trajectory(joints, [(0.5, target)]), 0.3),
            "effort": _with_effort(trajectory(joints, [(0.5, target)])),
        }
        for case, message in cases.items():
            if message is None:
                continue
            before, logs = d.positions(joints), d.log_count()
            publisher.publish(message)
            d.sleep(0.8)
            out[f"{controller}/{case}"] = {"moved": _moved(d, joints, before), "logged": d.rejected_logs(logs)[:1]}
    return out


def _with_velocity(message: JointTrajectory, speed: float) -> JointTrajectory:
    message.points[-1].velocities = [speed] * len(message.joint_names)
    return message


def _with_effort(message: JointTrajectory) -> JointTrajectory:
    message.points[-1].effort = [0.1] * len(message.joint_names)
    return message


def semantics(d: Driver) -> dict[str, Any]:
    """Jazzy JTC's topic, case by case: a partial trajectory (hand: the joints left out keep their command; arm:
    rejected as partial goals are), a repeated name on the hand (the first occurrence counts), replacement of a
    running trajectory, and a topic trajectory during an action goal (the goal goes on against it)."""
    hand, joints = d.hand, d.trajectory[d.hand]
    publisher = d.publisher(hand)
    out: dict[str, Any] = {}
    before = d.positions(joints)
    publisher.publish(trajectory(joints[:1], [(0.5, [0.4])]))
    d.sleep(1.5)
    after = d.positions(joints)
    out["partial"] = {"named": abs(after[0] - 0.4), "others": max(abs(a - b) for a, b in zip(after[1:], before[1:]))}
    publisher.publish(trajectory([joints[0], joints[0]], [(0.5, [0.2, 0.6])]))
    d.sleep(1.5)
    out["repeated_first_wins"] = abs(d.positions(joints[:1])[0] - 0.2)
    far, near = d.mid(joints, 0.9), d.mid(joints, 0.3)
    publisher.publish(trajectory(joints, [(3.0, far)]))
    d.sleep(0.5)
    publisher.publish(trajectory(joints, [(1.0, near)]))
    d.sleep(2.0)
    out["replaced"] = max(abs(a - b) for a, b in zip(d.positions(joints), near))
    out["goal_then_topic"] = _goal_then_topic(d, publisher, joints)
    out["query_state"] = _query(d, publisher, joints)
    return out


def _goal_then_topic(d: Driver, publisher: Any, joints: list[str]) -> dict[str, Any]:
    action = ActionClient(d.node, FollowJointTrajectory, f"/{d.hand}/follow_joint_trajectory")
    if not action.wait_for_server(timeout_sec=WALL):
        raise TimeoutError("no action server")
    goal = FollowJointTrajectory.Goal(trajectory=trajectory(joints, [(4.0, d.mid(joints, 0.8))]))
    handle = wait(action.send_goal_async(goal))
    d.sleep(0.5)
    topic_target = d.mid(joints, 0.2)
    publisher.publish(trajectory(joints, [(1.0, topic_target)]))
    result = wait(handle.get_result_async(), WALL)
    ended = d.now()
    d.sleep(1.0)  # the goal ends with the trajectory (its tolerances are JTC's defaults, 0: unchecked)
    return {
        "status": int(result.status),
        "error_code": int(result.result.error_code),
        "error": max(abs(a - b) for a, b in zip(d.positions(joints), topic_target)),
        "ended_at": ended,
    }


def _query(d: Driver, publisher: Any, joints: list[str]) -> dict[str, Any]:
    client = d.service(QueryTrajectoryState, f"/{d.hand}/query_state")
    target = d.mid(joints, 0.6)
    publisher.publish(trajectory(joints, [(2.0, target)]))
    d.sleep(0.3)
    request = QueryTrajectoryState.Request()
    at = d.now() + 0.5
    request.time.sec, request.time.nanosec = int(at), int((at - int(at)) * 1e9)
    during = wait(client.call_async(request))
    d.sleep(2.5)
    at = d.now()
    request.time.sec, request.time.nanosec = int(at), int((at - int(at)) * 1e9)
    after = wait(client.call_async(request))
    return {
        "during": {"success": during.success, "names": list(during.name), "size": len(during.position)},
        "after": {"success": after.success},
    }


def hardware(d: Driver) -> dict[str, Any]:
    """/svh/initialized (latched), /dynamic_joint_states, joint_states' order, /robot_description, /tf."""
    deadline = time.monotonic() + 15.0  # all come within a second of the start
    wanted = ("/svh/initialized", "/robot_description")
    while time.monotonic() < deadline:
        with d._lock:
            tf = bool(d.tf) and bool(d.tf_static)
        if tf and d.dynamic is not None and all(t in d.latched for t in wanted):
            break
        time.sleep(0.05)
    d.sleep(0.2)  # a few /tf messages more: every moving joint's transform has come
    dynamic = d.dynamic
    interfaces, order = {}, {}
    if dynamic is not None:
        for name, value in zip(dynamic.joint_names, dynamic.interface_values):
            interfaces[name] = dict(zip(value.interface_names, value.values))
            order[name] = list(value.interface_names)
    description = d.latched.get("/robot_description")
    with d._lock:
        tf = sorted(f"{p}>{c}" for p, c in d.tf)
        tf_static = sorted(f"{p}>{c}" for p, c in d.tf_static)
        names = list(d.joint_names)
    urdf = ET.fromstring(description.data) if description is not None else None
    urdf_joints = {} if urdf is None else {j.get("name"): j for j in urdf.iter("joint")}
    expected_tf = sorted(
        f"{j.find('parent').get('link')}>{j.find('child').get('link')}"
        for j in urdf_joints.values()
        if j.get("type") != "fixed"
    )
    expected_static = sorted(
        f"{j.find('parent').get('link')}>{j.find('child').get('link')}"
        for j in urdf_joints.values()
        if j.get("type") == "fixed"
    )
    return {
        "initialized": getattr(d.latched.get("/svh/initialized"), "data", None),
        "interfaces": interfaces,
        "interface_order": order,
        "channels": d.channels,
        "joint_states_order": names,
        "system_order": d.system_joints,
        "description_robot": None if urdf is None else urdf.get("name"),
        "tf": tf,
        "tf_expected": expected_tf,
        "tf_static": tf_static,
        "tf_static_expected": expected_static,
    }


def graph(d: Driver) -> dict[str, Any]:
    """Node names, who publishes what, and each controller's parameters read by a parameter client."""
    nodes = sorted(n for n, ns in d.node.get_node_names_and_namespaces() if ns == "/")
    publishers = {}
    for topic in ("/joint_states", "/dynamic_joint_states", "/svh/initialized", "/tf", "/robot_description"):
        publishers[topic] = sorted(i.node_name for i in d.node.get_publishers_info_by_topic(topic))
    for name in d.trajectory:
        topic = f"/{name}/controller_state"
        publishers[topic] = sorted(i.node_name for i in d.node.get_publishers_info_by_topic(topic))
    services = sorted(s for s, _ in d.node.get_service_names_and_types_by_node("controller_manager", "/"))
    parameters = {}
    manager = d.config["controller_manager"]["ros__parameters"]
    for name in [n for n, v in manager.items() if isinstance(v, dict)]:
        wanted = _flat(d.config.get(name, {}).get("ros__parameters", {}))
        try:
            client = d.service(GetParameters, f"/{name}/get_parameters", timeout=5.0)
        except TimeoutError:  # no node of that name serves parameters
            parameters[name] = {"expected": wanted, "read": None}
            continue
        got = wait(client.call_async(GetParameters.Request(names=list(wanted))))
        parameters[name] = {"expected": wanted, "read": {k: _value(v) for k, v in zip(wanted, got.values)}}
    with d._lock:
        steps = {n: _steps(s) for n, s in d.controller_states.items()}
    return {
        "nodes": nodes,
        "publishers": publishers,
        "manager_services": services,
        "parameters": parameters,
        "state_steps": steps,
    }


def _steps(stamps: list[float]) -> list[float]:
    return sorted({round(b - a, 4) for a, b in zip(stamps[-50:], stamps[-49:])})


def _flat(parameters: dict, prefix: str = "") -> dict[str, Any]:
    out = {}
    for key, value in parameters.items():
        if isinstance(value, dict):
            out.update(_flat(value, f"{prefix}{key}."))
        else:
            out[f"{prefix}{key}"] = value
    return out


def _value(value: Any) -> Any:
    """rcl_interfaces/ParameterValue as a plain value (type 1 bool, 2 int, 3 double, 4 string, 9 string array)."""
    kinds = {1: "bool_value", 2: "integer_value", 3: "double_value", 4: "string_value", 9: "string_array_value"}
    field = kinds.get(value.type)
    if field is None:
        return None
    read = getattr(value, field)
    return list(read) if value.type == 9 else read


def flood(d: Driver, rate: float = 1000.0, seconds: float = 10.0) -> dict[str, Any]:
    """Topic trajectories at ``rate`` for ``seconds`` (wall), every tenth malformed: the node's resident memory
    (/proc) and /clock's largest wall gap during the flood, and whether the node still moves the hand after."""
    joints = d.trajectory[d.hand]
    publisher = d.publisher(d.hand)
    good = [trajectory(joints, [(0.2, d.mid(joints, f))]) for f in (0.3, 0.7)]
    bad = trajectory([*joints[:-1], "no_such_joint"], [(0.2, d.mid(joints, 0.5))])
    memory = [_rss(d.pid)]
    begin = time.monotonic()
    with d._lock:
        first_clock = len(d.clock)
    sent = 0
    while time.monotonic() - begin < seconds:
        publisher.publish(bad if sent % 10 == 9 else good[sent % 2])
        sent += 1
        if sent % 1000 == 0:
            memory.append(_rss(d.pid))
        next_at = begin + sent / rate
        pause = next_at - time.monotonic()
        if pause > 0:
            time.sleep(pause)
    wall = time.monotonic() - begin
    d.sleep(0.5)
    memory.append(_rss(d.pid))
    with d._lock:
        walls = [w for w, _ in d.clock[first_clock:]]
    gap = max((b - a for a, b in zip(walls, walls[1:])), default=math.inf)
    target = d.mid(joints, 0.25)  # a pose the hand reaches without touching itself
    publisher.publish(trajectory(joints, [(0.5, target)]))
    d.sleep(2.0)
    return {
        "sent": sent,
        "wall": wall,
        "rss_kb": memory,
        "clock_gap": gap,
        "clock_messages": len(walls),
        "after": max(abs(a - b) for a, b in zip(d.positions(joints), target)),
    }


def _rss(pid: int) -> int:
    for line in Path(f"/proc/{pid}/status").read_text().splitlines():
        if line.startswith("VmRSS:"):
            return int(line.split()[1])
    return -1


CHECKS: dict[str, Callable[[Driver], Any]] = {
    "startup": startup,
    "hardware": hardware,
    "graph": graph,
    "example": example,
    "semantics": semantics,
    "bad_input": bad_input,
    "flood": flood,
}


def main() -> None:
    variant_dir, out, pid, wanted = Path(sys.argv[1]), Path(sys.argv[2]), int(sys.argv[3]), sys.argv[4:]
    rclpy.init(args=["driver_client"])
    d = Driver(variant_dir, pid)
    d.ready()
    report: dict[str, Any] = {"variant": d.variant, "hand": d.hand, "controllers": sorted(d.trajectory)}
    for name in wanted:
        began = time.monotonic()
        try:
            report[name] = CHECKS[name](d)
        except Exception as exc:  # noqa: BLE001 - the report says which check broke and why
            report[name] = {"error": f"{type(exc).__name__}: {exc}"}
        report.setdefault("wall", {})[name] = round(time.monotonic() - began, 2)
    out.write_text(json.dumps(report, indent=1, sort_keys=True))
    d.executor.shutdown(timeout_sec=5.0)
    d.node.destroy_node()
    rclpy.try_shutdown()
    sys.stdout.flush()
    os._exit(0)  # as tests/ros2/client.py: Python's exit aborts in a DDS thread's destructor


if __name__ == "__main__":
    main()
