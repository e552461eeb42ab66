"""``svhdesc plan --execute --ros2``: rclpy to a running ``svhdesc sim --ros2``, through the controllers the variant's
``ros2/config/moveit_controllers.yaml`` names (hand joints under SCHUNK's ROS 2 names,
``svhdesc.model.ros2_joint_name``); the tracking error from each controller's ``controller_state``
(JointTrajectoryControllerState.error), as ros2_controllers' JTC publishes it.

Runs in the ROS 2 venv (``.venv-ros2``, which ``tools/install.sh ros2`` gives the ``plan`` extra too). The node uses
simulated time; every wait is bounded by a wall-clock timeout.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable, Iterable, Sequence
from typing import Any

from svhdesc.errors import SvhdescError
from svhdesc.model import ros2_joint_name
from svhdesc.plan.execute import ControllerGoal
from svhdesc.ros2.system import import_rclpy

SERVER_WAIT = 60.0  # s (wall) for an action server, an answer or the first /joint_states (a busy machine)
SETTLE = 0.3  # s (simulated) after the last result before the final positions are read, as the ROS 1 executor


def _wait(future: Any, timeout: float, what: str) -> Any:
    done = threading.Event()
    future.add_done_callback(lambda _: done.set())
    if not done.wait(timeout):
        raise SvhdescError(f"{what}: no answer within {timeout:.1f} s")
    return future.result()


def _duration(seconds: float) -> Any:
    from builtin_interfaces.msg import Duration

    whole = int(seconds)
    return Duration(sec=whole, nanosec=int(round((seconds - whole) * 1e9)))


class Ros2:
    """The ``Transport`` of ``svhdesc.plan.execute`` over ROS 2; ``joints``: every joint name of the plan's robot (the
    URDF's), to read ROS 2 names back."""

    def __init__(self, joints: Iterable[str]) -> None:
        rclpy = import_rclpy()
        from rclpy.executors import SingleThreadedExecutor
        from rclpy.parameter import Parameter
        from sensor_msgs.msg import JointState

        self._back = {ros2_joint_name(j): j for j in joints}
        self._rclpy, self._owns_context = rclpy, not rclpy.ok()
        if self._owns_context:
            rclpy.init()
        self._node = rclpy.create_node(
            "svhdesc_plan", parameter_overrides=[Parameter("use_sim_time", Parameter.Type.BOOL, True)]
        )
        self._lock = threading.Lock()
        self._state: Any = None
        self._node.create_subscription(JointState, "/joint_states", self._on_joint_state, 10)
        self._executor = SingleThreadedExecutor()
        self._executor.add_node(self._node)
        self._spinner = threading.Thread(target=self._executor.spin, daemon=True)
        self._spinner.start()

    def _on_joint_state(self, message: Any) -> None:
        with self._lock:
            self._state = message

    def _stamp(self) -> float:
        with self._lock:
            state = self._state
        return -1.0 if state is None else state.header.stamp.sec + 1e-9 * state.header.stamp.nanosec

    def _state_after(self, stamp: float) -> Any:
        deadline = time.monotonic() + SERVER_WAIT
        while self._stamp() < stamp:
            if time.monotonic() > deadline:
                raise SvhdescError("no /joint_states: start svhdesc sim --ros2 first")
            time.sleep(0.005)
        with self._lock:
            return self._state

    def positions(self) -> dict[str, float]:
        message = self._state_after(0.0)
        return {self._back.get(n, n): float(p) for n, p in zip(message.name, message.position)}

    def _on_executor(self, request: Callable[[], Any], what: str) -> Any:
        """The future ``request`` returns, called on the executor's thread: Jazzy's ActionClient files a request's
        future only after sending it, and a reply taken in between is dropped."""
        return _wait(self._executor.create_task(request), SERVER_WAIT, what)

    def follow(self, goals: Sequence[ControllerGoal], wait: float) -> tuple[dict[str, tuple[int, str]], float]:
        from control_msgs.action import FollowJointTrajectory
        from control_msgs.msg import JointTrajectoryControllerState
        from rclpy.action import ActionClient

        errors: list[float] = []

        def on_state(message: Any) -> None:
            with self._lock:
                errors.append(max((abs(e) for e in message.error.positions), default=0.0))

        clients, subscriptions = {}, []
        try:
            for goal in goals:
                name = goal.controller.name
                action = f"/{name}/{goal.controller.action_ns}"
                clients[name] = ActionClient(self._node, FollowJointTrajectory, action)
                if not clients[name].wait_for_server(timeout_sec=SERVER_WAIT):
                    raise SvhdescError(f"no action server {action}")
                subscriptions.append(
                    self._node.create_subscription(
                        JointTrajectoryControllerState, f"/{name}/controller_state", on_state, 10
                    )
                )
            handles = {
                goal.controller.name: self._send(
                    clients[goal.controller.name], self._message(goal, FollowJointTrajectory)
                )
                for goal in goals
            }
            results = {name: self._result(name, handle, wait) for name, handle in handles.items()}
            self._state_after(self._stamp() + SETTLE)
        finally:
            for subscription in subscriptions:
                self._node.destroy_subscription(subscription)
            for client in clients.values():
                client.destroy()
        with self._lock:
            return results, max(errors, default=0.0)

    def _send(self, client: Any, message: Any) -> Any:
        future = self._on_executor(lambda: client.send_goal_async(message), "send_goal")
        return _wait(future, SERVER_WAIT, "the goal's acceptance")

    def _result(self, name: str, handle: Any, wait: float) -> tuple[int, str]:
        if not handle.accepted:
            return -99, "goal rejected"
        future = self._on_executor(handle.get_result_async, "get_result")
        try:
            answer = _wait(future, wait, f"{name}'s result")
        except SvhdescError:
            self._on_executor(handle.cancel_goal_async, "cancel")
            raise
        return int(answer.result.error_code), answer.result.error_string

    def _message(self, goal: ControllerGoal, action: Any) -> Any:
        from trajectory_msgs.msg import JointTrajectoryPoint

        message = action.Goal()
        message.trajectory.joint_names = [ros2_joint_name(j) for j in goal.joints]
        message.trajectory.points = [
            JointTrajectoryPoint(
                positions=list(p), velocities=list(v), accelerations=list(a), time_from_start=_duration(t)
            )
            for t, p, v, a in zip(goal.times, goal.positions, goal.velocities, goal.accelerations)
        ]
        return message

    def close(self) -> None:
        """Stop spinning and wait for the executor's thread before the node and the context go: a thread still in
        rclpy's wait when the interpreter exits aborts the process ("terminate called without an active exception")."""
        self._executor.shutdown()
        self._spinner.join(timeout=SERVER_WAIT)
        self._node.destroy_node()
        if self._owns_context:
            self._rclpy.shutdown()
