"""The policy node (rclpy + onnxruntime): a trained actor closing the loop through the ROS 2 drivers' interfaces.

It reads ``/joint_states`` and each task object's ``/tracked/<object>`` pose, and commands the forward position
controllers of the variant's ``ros2_controllers.yaml`` (swapped in for the trajectory controllers of the same
joints) at the task's control rate on simulated time. See svhdesc.learn.deploy for the whole arrangement.
"""

from __future__ import annotations

import threading
import time
from pathlib import Path
from typing import Any

from svhdesc.errors import SvhdescError
from svhdesc.learn.deploy import SETTLE, Observer
from svhdesc.learn.spec import Task

WALL = 120.0  # s of wall time to wait for the node's services and first messages


def forward_plan(variant: str) -> tuple[list[tuple[str, list[str]]], list[str]]:
    """([(forward controller, its joints in command order)], the trajectory controllers over those joints)."""
    from svhdesc.model import ROS2_FORWARD_TYPE
    from svhdesc.ros2.node import controllers_file, read_controllers

    _, types, parameters = read_controllers(controllers_file(variant))
    forward = [(name, list(parameters[name]["joints"])) for name, kind in types.items() if kind == ROS2_FORWARD_TYPE]
    claimed = {joint for _, joints in forward for joint in joints}
    trajectory = [
        name
        for name, kind in types.items()
        if kind != ROS2_FORWARD_TYPE and claimed & set(parameters[name].get("joints", []))
    ]
    if not forward:
        raise SvhdescError(f"{controllers_file(variant)}: no forward position controller to command")
    return forward, trajectory


class PolicyNode:
    def __init__(self, task: Task, policy: Path, seed: int) -> None:
        from controller_manager_msgs.srv import ListControllers, SwitchController
        from geometry_msgs.msg import PoseStamped
        from rclpy.executors import SingleThreadedExecutor
        from rclpy.parameter import Parameter
        from sensor_msgs.msg import JointState
        from std_msgs.msg import Float64MultiArray

        from svhdesc.learn.policy import OnnxPolicy
        from svhdesc.model import ros2_joint_name
        from svhdesc.ros2.system import import_rclpy

        self.rclpy = import_rclpy()
        self.task, self.act = task, OnnxPolicy(policy, task)
        self.observer = Observer(task, seed)
        self.forward, self.trajectory = forward_plan(task.scene.variant)
        columns = [ros2_joint_name(self.observer.env.mjm.joint(int(j)).name) for j in self._actuated_joints()]
        self.order = [[columns.index(joint) for joint in joints] for _, joints in self.forward]
        self._lock = threading.Lock()
        self.positions: dict[str, float] = {}
        self.poses: dict[str, tuple[list[float], list[float]]] = {}
        self.stamp = -1.0
        node = self.rclpy.create_node(
            "svhdesc_policy", parameter_overrides=[Parameter("use_sim_time", Parameter.Type.BOOL, True)]
        )
        self.node = node
        node.create_subscription(JointState, "/joint_states", self._on_joints, 10)
        for body in self.observer.objects:
            node.create_subscription(PoseStamped, f"/tracked/{body}", lambda m, b=body: self._on_pose(b, m), 10)
        self.publishers = [
            node.create_publisher(Float64MultiArray, f"/{name}/commands", 10) for name, _ in self.forward
        ]
        self.message = Float64MultiArray
        self.list = node.create_client(ListControllers, "/controller_manager/list_controllers")
        self.switch = node.create_client(SwitchController, "/controller_manager/switch_controller")
        self.switch_type, self.list_type = SwitchController, ListControllers
        self.executor = SingleThreadedExecutor()
        self.executor.add_node(node)
        self.spinning = threading.Thread(target=self.executor.spin, daemon=True)
        self.spinning.start()

    def close(self) -> None:
        """Stop spinning before rclpy shuts down (a spinning executor raises at shutdown)."""
        self.executor.shutdown()
        self.spinning.join(timeout=5.0)
        self.node.destroy_node()

    def _actuated_joints(self) -> list[int]:
        m = self.observer.env.mjm
        return [int(m.actuator_trnid[a, 0]) for a in range(m.nu)]

    def _on_joints(self, message: Any) -> None:
        with self._lock:
            self.positions.update(zip(message.name, message.position))
            self.stamp = max(self.stamp, message.header.stamp.sec + 1e-9 * message.header.stamp.nanosec)

    def _on_pose(self, body: str, message: Any) -> None:
        p, q = message.pose.position, message.pose.orientation
        with self._lock:
            self.poses[body] = ([p.x, p.y, p.z], [q.w, q.x, q.y, q.z])

    def _call(self, client: Any, request: Any) -> Any:
        if not client.wait_for_service(timeout_sec=WALL):
            raise SvhdescError(f"no service {client.srv_name}: is the simulation node running?")
        future = client.call_async(request)
        deadline = time.monotonic() + WALL
        while not future.done():
            if time.monotonic() > deadline:
                raise SvhdescError(f"{client.srv_name} did not answer")
            time.sleep(0.01)
        return future.result()

    def swap_in(self) -> None:
        """The forward controllers active, the trajectory controllers they replace inactive: one STRICT switch
        (Jazzy answers ok even where a conflict kept a controller inactive: list_controllers says)."""
        request = self.switch_type.Request(
            activate_controllers=[name for name, _ in self.forward],
            deactivate_controllers=self.trajectory,
            strictness=self.switch_type.Request.STRICT,
        )
        self._call(self.switch, request)
        states = {c.name: c.state for c in self._call(self.list, self.list_type.Request()).controller}
        inactive = [name for name, _ in self.forward if states.get(name) != "active"]
        if inactive:
            raise SvhdescError(f"controllers not active after switch_controller: {', '.join(inactive)} ({states})")

    def now(self) -> float:
        with self._lock:
            return self.stamp

    def wait_until(self, when: float) -> float:
        deadline = time.monotonic() + WALL
        while (now := self.now()) < when:
            if time.monotonic() > deadline:
                raise SvhdescError(f"no /joint_states at simulated time {when:.3f} s")
            time.sleep(0.001)
        return now

    def tick(self, now: float) -> None:
        with self._lock:
            positions, poses = dict(self.positions), dict(self.poses)
        missing = [body for body in self.observer.objects if body not in poses]
        if missing:
            raise SvhdescError(f"no pose of {', '.join(missing)} on /tracked/")
        self.observer.write(now, positions, poses)
        action = self.act(self.observer.actor())[0]
        targets = self.observer.acted(action)
        for publisher, order in zip(self.publishers, self.order):
            publisher.publish(self.message(data=[float(targets[k]) for k in order]))


def policy_node(task: Task, policy: Path, seed: int, duration: float) -> dict[str, Any]:
    """Run the policy node for ``duration`` simulated seconds after the controllers settle; its verdict."""
    from svhdesc.ros2.system import import_rclpy

    rclpy = import_rclpy()
    rclpy.init(args=["svhdesc_policy"])
    runner = None
    try:
        runner = PolicyNode(task, policy, seed)
        runner.wait_until(SETTLE)
        runner.swap_in()
        period = 1.0 / task.control_hz
        start = runner.now()
        ticks = 0
        while ticks * period < duration:
            now = runner.wait_until(start + ticks * period)
            runner.tick(now)
            ticks += 1
        verdict = runner.observer.verdict()
        verdict.update(task=task.name, ticks=ticks, controllers=[name for name, _ in runner.forward])
        return verdict
    finally:
        if runner is not None:
            runner.close()
        rclpy.try_shutdown()


def _main() -> int:
    import json
    import sys

    from svhdesc.learn.tasks import task

    name, policy, seed, duration = sys.argv[1], Path(sys.argv[2]), int(sys.argv[3]), float(sys.argv[4])
    print(json.dumps(policy_node(task(name), policy, seed, duration)), flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(_main())
