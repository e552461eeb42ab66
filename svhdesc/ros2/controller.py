"""One joint_trajectory_controller over ROS 2 (rclpy): a ``control_msgs/action/FollowJointTrajectory`` server at
``<controller>/follow_joint_trajectory`` and ``<controller>/controller_state``
(``control_msgs/msg/JointTrajectoryControllerState``), as ros2_controllers' Jazzy JTC serves them. The semantics are
svhdesc.control.trajectory's with ``JAZZY``; this adapter converts messages and answers goal handles.

Threads: rclpy's executor thread answers goal requests at once, as JTC's goal_received_callback does (a read-only
check: rejected goals get no result, only the rejection), and runs each accepted goal's execute coroutine, which
queues the goal for the simulation thread and awaits its end. Everything that touches the simulation runs on the
simulation thread (node.py drains the queue every control update).
"""

from __future__ import annotations

import re
import threading
from collections import deque
from collections.abc import Callable, Mapping, Sequence
from typing import Any

import numpy as np

from svhdesc.control.goals import ErrorCode, Rejection, Tolerances, points_of
from svhdesc.control.outbox import Outbox
from svhdesc.control.trajectory import JAZZY, ForwardsToCore, Goal, JointTrajectoryCore, Result, Sample, Status
from svhdesc.control.work import Latest, on_sim_thread
from svhdesc.model import ACTION
from svhdesc.ros2.graph import Prefilled
from svhdesc.sim import Simulation

UNKNOWN = "<not a joint of this controller>:"  # an unknown name can never match a simulation joint
# Requests (goals, cancels, result requests) DDS keeps for the node before rclpy's executor takes them. rclpy's (and
# rcl_action's) default service QoS keeps the last 10 (KEEP_LAST, reliable); a burst overflowed the goal service's
# reader and DDS dropped the oldest requests unseen (300 goals at once: 19 reached the node). Goal requests are
# small: 1000 queued hold about 1 MB.
REQUEST_DEPTH = 1000


def request_qos() -> Any:
    """The services' default QoS (reliable, volatile, KEEP_LAST) with REQUEST_DEPTH."""
    from rclpy.qos import QoSProfile, qos_profile_services_default

    return QoSProfile(
        history=qos_profile_services_default.history,
        depth=REQUEST_DEPTH,
        reliability=qos_profile_services_default.reliability,
        durability=qos_profile_services_default.durability,
    )


def seconds(value: Any) -> float:
    """builtin_interfaces Time or Duration in seconds."""
    return float(value.sec) + 1e-9 * float(value.nanosec)


def stamp(time_class: Any, at: float) -> Any:
    """builtin_interfaces/Time of ``at`` seconds."""
    whole, nanoseconds = divmod(int(round(at * 1e9)), 1_000_000_000)
    return time_class(sec=whole, nanosec=nanoseconds)


EFFORT = "Trajectories with effort fields are only supported for controllers using the 'effort' command interface."


def trajectory_goal(request: Any, to_sim: Mapping[str, str]) -> Goal | Rejection:
    """A FollowJointTrajectory goal (ROS 2 joint names) as the core's Goal (simulation joint names)."""

    def sim(name: str) -> str:
        return to_sim.get(name, UNKNOWN + name)

    try:
        goal = topic_goal(request.trajectory, to_sim)
        if isinstance(goal, Rejection):
            return goal
        return Goal(
            goal.joint_names,
            goal.points,
            goal.stamp,
            {sim(t.name): t.position for t in request.path_tolerance},
            {sim(t.name): t.velocity for t in request.path_tolerance},
            {sim(t.name): t.position for t in request.goal_tolerance},
            {sim(t.name): t.velocity for t in request.goal_tolerance},
            seconds(request.goal_time_tolerance),
        )
    except (TypeError, ValueError, AttributeError) as exc:  # a malformed message
        return Rejection(ErrorCode.INVALID_GOAL, f"malformed goal: {exc}")


def topic_goal(trajectory: Any, to_sim: Mapping[str, str]) -> Goal | Rejection:
    """A trajectory_msgs/JointTrajectory (a goal's, or one from ``~/joint_trajectory``) as the core's Goal; a point
    with efforts is refused as Jazzy's JTC refuses it on a position-commanded controller."""
    try:
        if any(len(point.effort) for point in trajectory.points):
            return Rejection(ErrorCode.INVALID_GOAL, EFFORT)
        return Goal(
            [to_sim.get(n, UNKNOWN + n) for n in trajectory.joint_names],
            points_of(trajectory.points, seconds),
            seconds(trajectory.header.stamp),
        )
    except (TypeError, ValueError, AttributeError) as exc:  # a malformed message
        return Rejection(ErrorCode.INVALID_GOAL, f"malformed trajectory: {exc}")


class _Goal:
    """An accepted goal: rclpy's goal handle and the future its execute coroutine awaits."""

    def __init__(self, goal_handle: Any, future: Any) -> None:
        self.goal_handle = goal_handle
        self.future = future


class TrajectoryController(ForwardsToCore):
    def __init__(
        self,
        node: Any,
        name: str,
        joints: Sequence[str],
        to_ros: Mapping[str, str],
        sim: Simulation,
        allow_partial: bool,
        defaults: Tolerances,
        queue: deque,
        wake: Callable[[], None],
        feedback_period: float,
        state_period: float,
        reports_velocity: bool,
        callback_group: Any = None,
    ) -> None:
        """``joints``: the simulation's names; ``to_ros`` maps them to the ROS 2 driver's. ``wake`` wakes the
        executor after the simulation thread finished a goal (its execute coroutine then returns)."""
        from action_msgs.msg import GoalStatus
        from builtin_interfaces.msg import Time
        from control_msgs.action import FollowJointTrajectory
        from control_msgs.msg import JointTrajectoryControllerState
        from rclpy.task import Future

        self._Time, self._Action, self._Future = Time, FollowJointTrajectory, Future
        self._canceling = GoalStatus.STATUS_CANCELING
        self.name, self.joints = name, list(joints)
        self._ros_names = [to_ros[j] for j in joints]
        self._to_ros = dict(to_ros)
        self._to_sim = {to_ros[j]: j for j in joints}
        self._node, self._queue, self._wake = node, queue, wake
        self._lock = threading.Lock()
        self.recorder: Callable[[str, Any, float], None] | None = None  # (topic, message, time): --record
        self.outbox: Outbox | None = None  # state and feedback are published from its thread (None: at once)
        self.core = JointTrajectoryCore(
            name,
            joints,
            sim,
            self,
            allow_partial,
            defaults,
            feedback_period,
            state_period,
            True,
            reports_velocity,
            semantics=JAZZY,
        )
        self._state_message = JointTrajectoryControllerState()
        self._feedback_message = FollowJointTrajectory.Feedback()
        self._state = node.create_publisher(JointTrajectoryControllerState, f"{name}/controller_state", 10)
        self._state_bytes = state_template(self._ros_names)
        self._server = self._action_server(node, callback_group)
        self._topic = self._subscribe(node, callback_group)
        self._query = self._query_service(node, callback_group)

    def _subscribe(self, node: Any, callback_group: Any) -> Any:
        """``~/joint_trajectory`` as Jazzy's JTC subscribes it (system-default QoS). Each message is checked on
        the executor's thread (a rejected one is logged there, as validate_trajectory_msg logs); a valid one waits
        for the simulation thread in a slot that keeps only the newest (JTC's realtime buffer does the same)."""
        from rclpy.qos import qos_profile_system_default
        from trajectory_msgs.msg import JointTrajectory

        latest = Latest(self._queue, self.on_topic)
        self._topic_slot = latest

        def received(message: Any) -> None:
            goal = topic_goal(message, self._to_sim)
            rejection = goal if isinstance(goal, Rejection) else self.core.check(goal)
            if rejection is not None:
                self._node.get_logger().error(
                    f"{self.name}/joint_trajectory: rejected: {self._renamed(rejection.reason)}"
                )
                return
            latest(goal)

        return node.create_subscription(
            JointTrajectory,
            f"{self.name}/joint_trajectory",
            received,
            qos_profile_system_default,
            callback_group=callback_group,
        )

    def _action_server(self, node: Any, callback_group: Any) -> Any:
        from control_msgs.action import FollowJointTrajectory
        from rclpy.action import ActionServer

        requests = {f"{kind}_service_qos_profile": request_qos() for kind in ("goal", "result", "cancel")}
        return ActionServer(
            node,
            FollowJointTrajectory,
            f"{self.name}/{ACTION}",  # relative: a node started in a namespace serves there
            execute_callback=self._execute,
            goal_callback=self._on_goal_request,
            cancel_callback=self._on_cancel,
            callback_group=callback_group,
            **requests,
        )

    def _query_service(self, node: Any, callback_group: Any) -> Any:
        from control_msgs.srv import QueryTrajectoryState

        return node.create_service(
            QueryTrajectoryState, f"{self.name}/query_state", self._on_query, callback_group=callback_group
        )

    def _on_query(self, request: Any, response: Any) -> Any:
        """Jazzy's query_state_service: every joint of the controller, sampled on the simulation thread."""
        when = seconds(request.time)
        answer = on_sim_thread(self._queue, lambda: self.core.sample_current(when))
        state, why = answer if isinstance(answer, tuple) else (None, str(answer))
        response.name = list(self._ros_names)
        response.success = state is not None
        if state is None:
            response.message = why
            self._node.get_logger().error(f"{self.name}: {why}")
            return response
        response.position = state.positions.tolist()
        response.velocity = state.velocities.tolist()
        response.acceleration = state.accelerations.tolist()
        return response

    # -- rclpy's executor thread -------------------------------------------------------------
    def _on_goal_request(self, request: Any) -> Any:
        """As JTC's goal_received_callback: accept, or reject at once (the client gets no result)."""
        from rclpy.action import GoalResponse

        rejection = self.core.check(trajectory_goal(request, self._to_sim))
        if rejection is not None:
            self.warn(f"{self.name}: goal rejected ({int(rejection.code)}): {rejection.reason}")
            return GoalResponse.REJECT
        return GoalResponse.ACCEPT

    def _on_cancel(self, goal_handle: Any) -> Any:
        from rclpy.action import CancelResponse

        self._queue.append((self.on_cancel, goal_handle))
        return CancelResponse.ACCEPT  # as JTC: a goal that is no longer active ends as it ended

    async def _execute(self, goal_handle: Any) -> Any:
        goal = _Goal(goal_handle, self._Future())
        self._queue.append((self.on_goal, goal))
        await goal.future
        status, result = goal.future.result()
        if status is Status.SUCCEEDED:
            goal_handle.succeed()
        elif status is Status.ABORTED:
            goal_handle.abort()
        else:
            if goal_handle.status != self._canceling:  # preempted or stopped, not canceled by its client
                _to_canceling(goal_handle)
            goal_handle.canceled()
        return result

    # -- the simulation thread ---------------------------------------------------------------
    def on_goal(self, goal: _Goal) -> None:
        if goal.goal_handle.is_cancel_requested:  # canceled before it reached the simulation: it never starts
            self._resolve(goal, Status.CANCELED, ErrorCode.SUCCESSFUL, "")
            return
        self.core.submit(trajectory_goal(goal.goal_handle.request, self._to_sim), goal)

    def on_topic(self, goal: Goal) -> None:
        """A checked ``~/joint_trajectory`` message (the simulation thread: checked again, time moved on)."""
        self.core.topic(goal)

    def on_cancel(self, goal_handle: Any) -> None:
        active = self.core.active_handle
        if self.core.cancel(lambda handle: handle.goal_handle is goal_handle):
            self._resolve(active, Status.CANCELED, ErrorCode.SUCCESSFUL, "")

    def _renamed(self, text: str) -> str:
        """The core's texts name the simulation's joints: say the ROS 2 driver's names. A name the goal gave that is
        not a joint here (UNKNOWN + the name) is said as the client sent it: a ROS 1 name such as
        ``right_hand_Pinky`` must not turn into the ROS 2 joint it is mistaken for."""
        for joint in sorted(self._to_ros, key=len, reverse=True):
            text = re.sub(rf"(?<![\w:]){re.escape(joint)}(?!\w)", self._to_ros[joint], text)
        return text.replace(UNKNOWN, "")

    def _resolve(self, goal: _Goal, status: Status, code: ErrorCode, text: str) -> None:
        result = self._Action.Result(error_code=int(code), error_string=self._renamed(text))
        with self._lock:
            if not goal.future.done():
                goal.future.set_result((status, result))
        self._wake()

    # -- the core's sink ---------------------------------------------------------------------
    def accepted(self, handle: Any) -> None:
        """rclpy accepted the goal already (the goal request's check)."""

    def rejected(self, handle: Any, rejection: Rejection) -> None:
        """The check on the simulation thread failed after rclpy's had passed (time moved on, or the controller
        was stopped meanwhile): the accepted goal aborts with the rejection's code."""
        self._resolve(handle, Status.ABORTED, rejection.code, rejection.reason)

    def finished(self, handle: Any, result: Result) -> None:
        self._resolve(handle, result.status, result.code, result.text)

    def warn(self, text: str) -> None:
        self._node.get_logger().warning(self._renamed(text))

    # The state and feedback messages are refilled, not built: an empty JointTrajectoryControllerState costs rclpy
    # ~0.1 ms (its nested defaults), a refill ~5 us; publish and the recorder serialise them in the call.
    def state(self, sample: Sample) -> None:
        if self.outbox is not None:
            self.outbox.add(self._publish_state, sample)
        else:
            self._publish_state(sample)

    def _publish_state(self, sample: Sample) -> None:
        """As bytes written into a serialized template (graph.Prefilled: no per-message conversion); the message
        itself is built only for the recorder."""
        at = stamp(self._Time, sample.stamp)
        wanted = sample.desired
        values = np.concatenate(
            [
                wanted.positions,
                wanted.velocities,
                wanted.accelerations,
                sample.actual_positions,
                sample.actual_velocities,
                sample.position_error,
                sample.velocity_error,
                wanted.positions,  # output: the position command interface
            ]
        )
        self._state.publish(self._state_bytes.payload(values, at.sec, at.nanosec))
        if self.recorder is not None:
            message = self._state_message
            message.header.stamp = at
            message.joint_names = [self._to_ros[j] for j in sample.joints]
            _fill(message.reference, message.feedback, message.error, sample)
            message.output.positions = message.reference.positions
            self.recorder(self._state.topic_name, message, sample.stamp)

    def feedback(self, handle: Any, sample: Sample) -> None:
        if self.outbox is not None:
            self.outbox.add(lambda s: self._publish_feedback(handle, s), sample)
        else:
            self._publish_feedback(handle, sample)

    def _publish_feedback(self, handle: Any, sample: Sample) -> None:
        message = self._feedback_message
        message.header.stamp = stamp(self._Time, sample.stamp)
        message.joint_names = [self._to_ros[j] for j in sample.joints]
        _fill(message.desired, message.actual, message.error, sample)
        handle.goal_handle.publish_feedback(message)


def state_template(names: Sequence[str]) -> Prefilled:
    """JointTrajectoryControllerState as bytes: every joint of the controller (the core's state samples them all);
    reference positions, velocities, accelerations, feedback positions, velocities, error positions, velocities,
    output positions (8 n values, in that order) and the stamp."""
    from control_msgs.msg import JointTrajectoryControllerState
    from rclpy.serialization import serialize_message

    n = len(names)
    block = [[Prefilled.marker(k * n + i) for i in range(n)] for k in range(8)]
    message = JointTrajectoryControllerState(joint_names=list(names))
    message.reference.positions, message.reference.velocities, message.reference.accelerations = block[:3]
    message.feedback.positions, message.feedback.velocities = block[3:5]
    message.error.positions, message.error.velocities = block[5:7]
    message.output.positions = block[7]
    message.header.stamp.sec, message.header.stamp.nanosec = Prefilled.STAMP
    return Prefilled(serialize_message(message), 8 * n, 1)


def _fill(desired: Any, actual: Any, error: Any, sample: Sample) -> None:
    """Three JointTrajectoryPoints (reference or desired, feedback or actual, error) from a sample."""
    wanted = sample.desired
    desired.positions = wanted.positions.tolist()
    desired.velocities = wanted.velocities.tolist()
    desired.accelerations = wanted.accelerations.tolist()
    actual.positions = sample.actual_positions.tolist()
    actual.velocities = sample.actual_velocities.tolist()
    error.positions = sample.position_error.tolist()
    error.velocities = sample.velocity_error.tolist()


def _to_canceling(goal_handle: Any) -> None:
    """rclpy's goal handle has no public way from EXECUTING to CANCELED: JTC's preempt_active_goal and on_deactivate
    cancel a goal no client asked to cancel, so the goal takes the CANCEL_GOAL event first (rcl_action's state
    machine), as a client's cancel request would."""
    from rclpy.impl.implementation_singleton import rclpy_implementation

    goal_handle._update_state(rclpy_implementation.GoalEvent.CANCEL_GOAL)
