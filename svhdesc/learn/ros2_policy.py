"""The policy node (rclpy + onnxruntime): a trained actor closing the loop through the ROS 2 drivers' interfaces.

It reads ``/joint_states`` and each task object's ``/tracked/<object>`` pose and, at the task's control rate on
simulated time, sends the actor's servo targets one of two ways (``VIA``):

- ``trajectory`` (the default): through the trajectory controllers that are active, as SCHUNK's driver ships them
  (``joint_state_broadcaster`` and one JointTrajectoryController, ``right_hand`` or ``left_hand``, at 125 Hz), with
  nothing switched: one ``trajectory_msgs/JointTrajectory`` of one point per control period on each controller's
  ``/<controller>/joint_trajectory``. The controllers are found with ``list_controllers`` (the active
  joint trajectory controllers claiming the policy's joints' position interfaces), not read from a file;
- ``forward``: the forward position controllers of the variant's ``ros2_controllers.yaml`` (on the real hand: the
  package's ``config/forward_position_controller.yaml`` added to the driver's), swapped in for the trajectory
  controllers of the same joints by one STRICT ``switch_controller``, each sent a ``Float64MultiArray`` in its own
  joint order.

The joints are the policy's actuated joints under their ROS 2 names (svhdesc.model.ros2_joint_name). See
svhdesc.learn.deploy for the whole arrangement.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from svhdesc.errors import SvhdescError
from svhdesc.learn.deploy import SETTLE, VIA, Observer
from svhdesc.learn.spec import Task

WALL = 120.0  # s of wall time to wait for the node's services and first messages
# A streamed point is due this many control periods after it is sent: reached as the next one arrives, so the
# commanded path is continuous (JTC interpolates from where the controller is to it).
LEAD_PERIODS = 1.0


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


def trajectory_plan(controllers: Sequence[Any], joints: Sequence[str]) -> list[tuple[str, list[int]]]:
    """[(active trajectory controller, the indices into ``joints`` of those it commands)] from list_controllers'
    ``ControllerState``s: each joint goes to the active JointTrajectoryController (ur_robot_driver's scaled one too)
    that claims its position interface; a joint none claims is an error."""
    owner: dict[str, str] = {}
    for controller in controllers:
        if not controller.type.endswith("JointTrajectoryController") or controller.state != "active":
            continue
        for interface in controller.claimed_interfaces:
            joint, _, kind = interface.rpartition("/")
            if kind == "position":
                owner.setdefault(joint, controller.name)
    missing = [joint for joint in joints if joint not in owner]
    if missing:
        seen = ", ".join(f"{c.name} ({c.state})" for c in controllers) or "none"
        raise SvhdescError(
            f"no active joint trajectory controller commands {', '.join(missing)} (list_controllers: {seen}); "
            "SCHUNK's launch spawns right_hand or left_hand"
        )
    plan: dict[str, list[int]] = {}
    for index, joint in enumerate(joints):
        plan.setdefault(owner[joint], []).append(index)
    return list(plan.items())


def trajectory_message(message: Any, names: Sequence[str], positions: Sequence[float], lead: float) -> Any:
    """A JointTrajectory (``message``: its class) of one point: ``positions`` of ``names``, due ``lead`` s after
    the controller receives it (stamp 0: JTC starts a topic trajectory when it takes it)."""
    from builtin_interfaces.msg import Duration
    from trajectory_msgs.msg import JointTrajectoryPoint

    nanoseconds = round(lead * 1e9)
    point = JointTrajectoryPoint(
        positions=[float(p) for p in positions],
        time_from_start=Duration(sec=nanoseconds // 1_000_000_000, nanosec=nanoseconds % 1_000_000_000),
    )
    return message(joint_names=list(names), points=[point])


class PolicyNode:
    def __init__(self, task: Task, policy: Path, seed: int, via: str) -> None:
        from geometry_msgs.msg import PoseStamped
        from rclpy.executors import SingleThreadedExecutor
        from rclpy.parameter import Parameter
        from sensor_msgs.msg import JointState

        from svhdesc.learn.policy import OnnxPolicy
        from svhdesc.model import ros2_joint_name
        from svhdesc.ros2.system import import_rclpy

        if via not in VIA:
            raise SvhdescError(f"via must be one of {', '.join(VIA)}, not {via!r}")
        self.rclpy = import_rclpy()
        self.task, self.act, self.via = task, OnnxPolicy(policy, task), via
        self.observer = Observer(task, seed)
        m = self.observer.env.mjm
        self.columns = [ros2_joint_name(m.joint(int(m.actuator_trnid[a, 0])).name) for a in range(m.nu)]
        self.sends: list[tuple[Any, Any]] = []  # (publisher, the message of the targets) per controller
        self.commanded: list[str] = []
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
        self.executor = SingleThreadedExecutor()
        self.executor.add_node(node)
        self.spinning = threading.Thread(target=self.executor.spin, daemon=True)
        self.spinning.start()

    def close(self) -> None:
        """Stop spinning before rclpy shuts down (a spinning executor raises at shutdown)."""
        self.executor.shutdown()
        self.spinning.join(timeout=5.0)
        self.node.destroy_node()

    def _on_joints(self, message: Any) -> None:
        with self._lock:
            self.positions.update(zip(message.name, message.position))
            self.stamp = max(self.stamp, message.header.stamp.sec + 1e-9 * message.header.stamp.nanosec)

    def _on_pose(self, body: str, message: Any) -> None:
        p, q = message.pose.position, message.pose.orientation
        with self._lock:
            self.poses[body] = ([p.x, p.y, p.z], [q.w, q.x, q.y, q.z])

    def _call(self, service: Any, name: str, request: Any) -> Any:
        client = self.node.create_client(service, name)
        try:
            if not client.wait_for_service(timeout_sec=WALL):
                raise SvhdescError(f"no service {name}: is the simulation node running?")
            future = client.call_async(request)
            deadline = time.monotonic() + WALL
            while not future.done():
                if time.monotonic() > deadline:
                    raise SvhdescError(f"{name} did not answer")
                time.sleep(0.01)
            return future.result()
        finally:
            self.node.destroy_client(client)

    def controllers(self) -> list[Any]:
        """list_controllers' ControllerStates."""
        from controller_manager_msgs.srv import ListControllers

        return list(
            self._call(ListControllers, "/controller_manager/list_controllers", ListControllers.Request()).controller
        )

    def active(self) -> list[str]:
        return sorted(c.name for c in self.controllers() if c.state == "active")

    def engage(self) -> None:
        """Find (trajectory) or swap in (forward) the controllers to command, and make their publishers."""
        if self.via == "trajectory":
            self._engage_trajectory()
        else:
            self._engage_forward()

    def _engage_trajectory(self) -> None:
        from trajectory_msgs.msg import JointTrajectory

        lead = LEAD_PERIODS / self.task.control_hz
        for name, indices in trajectory_plan(self.controllers(), self.columns):
            names = [self.columns[k] for k in indices]
            publisher = self.node.create_publisher(JointTrajectory, f"/{name}/joint_trajectory", 10)
            self.sends.append(
                (
                    publisher,
                    lambda t, n=names, i=indices: trajectory_message(JointTrajectory, n, [t[k] for k in i], lead),
                )
            )
            self.commanded.append(name)

    def _engage_forward(self) -> None:
        """The forward controllers active, the trajectory controllers they replace inactive: one STRICT switch
        (Jazzy answers ok even where a conflict kept a controller inactive: list_controllers says)."""
        from controller_manager_msgs.srv import SwitchController
        from std_msgs.msg import Float64MultiArray

        forward, trajectory = forward_plan(self.task.scene.variant)
        request = SwitchController.Request(
            activate_controllers=[name for name, _ in forward],
            deactivate_controllers=trajectory,
            strictness=SwitchController.Request.STRICT,
        )
        self._call(SwitchController, "/controller_manager/switch_controller", request)
        active = self.active()
        inactive = [name for name, _ in forward if name not in active]
        if inactive:
            raise SvhdescError(f"controllers not active after switch_controller: {', '.join(inactive)} ({active})")
        for name, joints in forward:
            order = [self.columns.index(joint) for joint in joints]
            publisher = self.node.create_publisher(Float64MultiArray, f"/{name}/commands", 10)
            self.sends.append((publisher, lambda t, o=order: Float64MultiArray(data=[float(t[k]) for k in o])))
            self.commanded.append(name)

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
        for publisher, message in self.sends:
            publisher.publish(message(targets))


def policy_node(task: Task, policy: Path, seed: int, duration: float, via: str = VIA[0]) -> dict[str, Any]:
    """Run the policy node for ``duration`` simulated seconds after the controllers settle; its verdict, with the
    controllers it commanded and those active before it engaged and at the end."""
    from svhdesc.ros2.system import import_rclpy

    rclpy = import_rclpy()
    rclpy.init(args=["svhdesc_policy"])
    runner = None
    try:
        runner = PolicyNode(task, policy, seed, via)
        runner.wait_until(SETTLE)
        before = runner.active()
        runner.engage()
        period = 1.0 / task.control_hz
        start = runner.now()
        ticks = 0
        while ticks * period < duration:
            now = runner.wait_until(start + ticks * period)
            runner.tick(now)
            ticks += 1
        verdict = runner.observer.verdict()
        verdict.update(task=task.name, ticks=ticks, via=via, controllers=runner.commanded)
        verdict.update(active_before=before, active_after=runner.active())
        return verdict
    finally:
        if runner is not None:
            runner.close()
        rclpy.try_shutdown()


def _main() -> int:
    import json
    import sys

    from svhdesc.learn.tasks import task

    name, policy, seed, duration, via = (
        sys.argv[1],
        Path(sys.argv[2]),
        int(sys.argv[3]),
        float(sys.argv[4]),
        sys.argv[5],
    )
    print(json.dumps(policy_node(task(name), policy, seed, duration, via)), flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(_main())
