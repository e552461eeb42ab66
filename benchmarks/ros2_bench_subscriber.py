"""The subscriber side of benchmarks/sim_bench_ros2.py: an rclpy process of its own (run in .venv-ros2, inside the
benchmark's private network namespace) that subscribes every topic the ROS 2 node publishes and times its /clock.

    python ros2_bench_subscriber.py SPEC.json [NODE_PID]

SPEC: {"node": the node's name, "window": wall s timed, "warmup": wall s before it, "wall": the most any wait
takes, "goals": {controller: {"joints": [ROS 2 names], "positions": [...], "seconds": s}}}.

Every topic the node publishes gets a ``raw=True`` subscription (nothing deserialised), but /clock, read to measure
simulated time, and the action topics, which the ActionClients subscribe themselves (one goal per trajectory
controller keeps their feedback flowing). Prints one JSON line: simulated seconds per wall second over the window,
and the messages received per topic meanwhile; with NODE_PID, the CPU time of the node's threads over the window
(Linux's /proc schedstat: time on a core, time runnable but waiting for one). Imports nothing of svhdesc.
"""

from __future__ import annotations

import importlib
import json
import os
import sys
import threading
import time
from pathlib import Path
from typing import Any

import rclpy
from builtin_interfaces.msg import Duration
from control_msgs.action import FollowJointTrajectory
from rclpy.action import ActionClient
from rclpy.executors import SingleThreadedExecutor
from rosgraph_msgs.msg import Clock
from schedstat import thread_cpu  # this script's folder: benchmarks/
from trajectory_msgs.msg import JointTrajectoryPoint

ACTION_TOPIC = "/_action/"  # rcl_action's hidden topics (feedback, status): the ActionClients' own


def message_class(type_name: str) -> Any:
    """``pkg/msg/Type`` as its Python class."""
    package, kind, name = type_name.split("/")
    return getattr(importlib.import_module(f"{package}.{kind}"), name)


def wait_until(condition: Any, wall: float, what: str) -> None:
    deadline = time.monotonic() + wall
    while not condition():
        if time.monotonic() > deadline:
            raise TimeoutError(f"no {what} within {wall:g} s")
        time.sleep(0.05)


class Subscriber:
    def __init__(self, spec: dict[str, Any]) -> None:
        self.spec = spec
        self.node = rclpy.create_node("svhdesc_bench_subscriber")
        self.counts: dict[str, int] = {}
        self.subscriptions: dict[str, Any] = {}
        self.unsubscribed: dict[str, str] = {}
        self.clock: list[float] = []
        self.feedback: dict[str, int] = {name: 0 for name in spec["goals"]}
        self.actions = {
            name: ActionClient(self.node, FollowJointTrajectory, f"/{name}/follow_joint_trajectory")
            for name in spec["goals"]
        }
        self.executor = SingleThreadedExecutor()
        self.executor.add_node(self.node)
        threading.Thread(target=self.executor.spin, daemon=True).start()

    def _count(self, topic: str) -> Any:
        def on_message(_: Any) -> None:
            self.counts[topic] = self.counts.get(topic, 0) + 1

        return on_message

    def _on_clock(self, message: Clock) -> None:
        self.counts["/clock"] = self.counts.get("/clock", 0) + 1
        self.clock.append(message.clock.sec + 1e-9 * message.clock.nanosec)
        del self.clock[:-10]

    def published(self) -> dict[str, str]:
        """{topic: type} of every topic the node's process publishes: the simulation's node and the ros2_control
        graph's beside it (controller_manager, a node per controller, robot_state_publisher, svh): every node in
        the private namespace but this one."""
        topics: dict[str, str] = {}
        for name, namespace in self.node.get_node_names_and_namespaces():
            if name == self.node.get_name():
                continue
            try:
                found = self.node.get_publisher_names_and_types_by_node(name, namespace)
            except RuntimeError:  # rclpy's NodeNameNonExistentError: not discovered yet
                continue
            topics.update({topic: types[0] for topic, types in found if types})
        return topics

    def subscribe_all(self) -> int:
        """Subscribe what the node publishes and this process does not yet read; the number of topics covered."""
        for topic, type_name in self.published().items():
            if topic in self.subscriptions or topic in self.unsubscribed or ACTION_TOPIC in topic:
                continue
            if topic == "/clock":
                self.subscriptions[topic] = self.node.create_subscription(Clock, topic, self._on_clock, 10)
                continue
            try:
                cls = message_class(type_name)
            except (ImportError, AttributeError, ValueError) as exc:
                self.unsubscribed[topic] = f"{type_name}: {type(exc).__name__}"
                continue
            self.subscriptions[topic] = self.node.create_subscription(cls, topic, self._count(topic), 10, raw=True)
        return len(self.subscriptions)

    def send_goals(self) -> None:
        """One slow goal per trajectory controller (home -> the model's test keyframe), so feedback flows."""
        wall = self.spec["wall"]
        for name, goal_spec in self.spec["goals"].items():
            client = self.actions[name]
            if not client.wait_for_server(timeout_sec=wall):
                raise TimeoutError(f"no action server {name}")
            goal = FollowJointTrajectory.Goal()
            goal.trajectory.joint_names = list(goal_spec["joints"])
            whole = int(goal_spec["seconds"])
            point = JointTrajectoryPoint(
                positions=[float(p) for p in goal_spec["positions"]],
                time_from_start=Duration(sec=whole, nanosec=int(round((goal_spec["seconds"] - whole) * 1e9))),
            )
            goal.trajectory.points.append(point)
            # Sent from the executor's thread: Jazzy's ActionClient files the request's future only after sending
            # it, and drops a reply that the executor takes in between.
            sent = self.executor.create_task(
                lambda c=client, g=goal, n=name: c.send_goal_async(g, feedback_callback=lambda _: self._on_feedback(n))
            )
            wait_until(sent.done, wall, f"the {name} goal sent")
            future = sent.result()
            wait_until(future.done, wall, f"answer to the {name} goal")
            if not future.result().accepted:
                raise RuntimeError(f"{name} rejected the benchmark's goal")

    def _on_feedback(self, name: str) -> None:
        self.feedback[name] += 1

    def measure(self) -> dict[str, Any]:
        spec = self.spec
        wanted = {"/clock", "/joint_states", *(f"/{name}/controller_state" for name in spec["goals"])}
        wait_until(lambda: wanted <= set(self.published()), spec["wall"], "topics " + ", ".join(sorted(wanted)))
        self.subscribe_all()
        self.send_goals()
        wait_until(lambda: self.clock, spec["wall"], "/clock")
        time.sleep(spec["warmup"])
        self.subscribe_all()  # anything that appeared since
        self.counts = dict.fromkeys(self.subscriptions, 0)
        self.feedback = dict.fromkeys(self.feedback, 0)
        pid = spec.get("pid")
        threads0, sim0, wall0 = (thread_cpu(pid) if pid else {}), self.clock[-1], time.perf_counter()
        time.sleep(spec["window"])
        sim1, wall1, threads1 = self.clock[-1], time.perf_counter(), (thread_cpu(pid) if pid else {})
        used = {tid: [b - a for a, b in zip(threads0.get(tid, (0.0, 0.0)), times)] for tid, times in threads1.items()}
        return {
            "cpu": {  # per simulated second: the simulation (main) thread's time on a core and waiting for one; all
                "main": used.get(pid, [0.0, 0.0])[0] / (sim1 - sim0),
                "main_waiting": used.get(pid, [0.0, 0.0])[1] / (sim1 - sim0),
                "all": sum(run for run, _ in used.values()) / (sim1 - sim0),
            }
            if pid
            else None,
            "rate": (sim1 - sim0) / (wall1 - wall0),
            "simulated": sim1 - sim0,
            "wall": wall1 - wall0,
            "messages": dict(sorted(self.counts.items())),
            "feedback": self.feedback,
            "unsubscribed": self.unsubscribed,
        }


def main() -> None:
    spec = json.loads(Path(sys.argv[1]).read_text())
    spec["pid"] = int(sys.argv[2]) if len(sys.argv) > 2 else None
    rclpy.init(args=["svhdesc_bench_subscriber"])
    try:
        report = Subscriber(spec).measure()
    except (TimeoutError, RuntimeError) as exc:
        report = {"error": str(exc)}
    print(json.dumps(report, sort_keys=True), flush=True)
    sys.stdout.flush()
    # As tests/ros2/client.py: Python's exit may abort in a DDS thread's destructor; the line is out, so leave.
    os._exit(0)


if __name__ == "__main__":
    main()
