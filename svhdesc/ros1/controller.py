"""One JointTrajectoryController over ROS 1: a FollowJointTrajectory action server (actionlib), a
``command`` topic, ``state`` (JointTrajectoryControllerState) and ``query_state``
(QueryTrajectoryState). The semantics are svhdesc.control.trajectory's; this adapter converts messages
and answers goal handles. ROS callbacks only queue work; the simulation thread does it (see node.py).
"""

from __future__ import annotations

from collections import deque
from collections.abc import Callable, Sequence
from typing import Any

from svhdesc.control.goals import ErrorCode, Rejection, Tolerances, points_of
from svhdesc.control.trajectory import ForwardsToCore, Goal, JointTrajectoryCore, Result, Sample, Status
from svhdesc.control.work import Latest, on_sim_thread
from svhdesc.model import ACTION
from svhdesc.ros1.system import synchronous_publisher, time_out_stalled_subscribers
from svhdesc.sim import Simulation


def _duration(value: Any) -> float:
    return float(value.secs) + 1e-9 * float(value.nsecs)


def trajectory_goal(trajectory: Any, goal: Any = None) -> Goal | Rejection:
    """A JointTrajectory (and its FollowJointTrajectoryGoal's tolerances) as the core's Goal."""
    try:
        if goal is None:
            return Goal(
                list(trajectory.joint_names), points_of(trajectory.points, _duration), trajectory.header.stamp.to_sec()
            )
        return Goal(
            list(trajectory.joint_names),
            points_of(trajectory.points, _duration),
            trajectory.header.stamp.to_sec(),
            {t.name: t.position for t in goal.path_tolerance},
            {t.name: t.velocity for t in goal.path_tolerance},
            {t.name: t.position for t in goal.goal_tolerance},
            {t.name: t.velocity for t in goal.goal_tolerance},
            _duration(goal.goal_time_tolerance),
        )
    except (TypeError, ValueError, AttributeError) as exc:  # a malformed message
        return Rejection(ErrorCode.INVALID_GOAL, f"malformed goal: {exc}")


RESULT_QUEUE = 2000  # results queued per connection before rospy drops the oldest (actionlib's own: 50)


class TrajectoryController(ForwardsToCore):
    def __init__(
        self,
        name: str,
        joints: Sequence[str],
        sim: Simulation,
        msgs: Any,
        allow_partial: bool,
        defaults: Tolerances,
        queue: deque,
        send: Callable[[list[tuple[Any, Any]]], None] | None = None,
        feedback_period: float = 0.05,
        state_period: float = 0.02,
        running: bool = True,
        reports_velocity: bool = True,
        update_period: float = 0.0,
    ) -> None:
        """``send`` hands (callable, message) pairs to a publishing thread (default: call at once)."""
        import actionlib
        import rospy
        from trajectory_msgs.msg import JointTrajectory

        self.name = name
        self.joints = list(joints)
        self._msgs = msgs
        self._rospy = rospy
        self._queue = queue
        self._send = send or (lambda batch: [target(message) for target, message in batch])
        self.core = JointTrajectoryCore(
            name,
            joints,
            sim,
            self,
            allow_partial,
            defaults,
            feedback_period,
            state_period,
            running,
            reports_velocity,
            update_period=update_period,  # by name: the core's later parameters (semantics) come before it
        )
        self._server = actionlib.ActionServer(
            f"{name}/{ACTION}",  # relative: a node started in a namespace serves there
            msgs.FollowJointTrajectoryAction,
            lambda handle: queue.append((self.on_goal, handle)),
            lambda handle: queue.append((self.on_cancel, handle)),
            auto_start=False,
        )
        self._command = rospy.Subscriber(
            f"{name}/command", JointTrajectory, Latest(queue, self.on_command), queue_size=1
        )
        self._state = synchronous_publisher(f"{name}/state", msgs.JointTrajectoryControllerState)
        self._state_message = msgs.JointTrajectoryControllerState()
        self._feedback_message = msgs.FollowJointTrajectoryFeedback()
        self._query = rospy.Service(f"{name}/query_state", msgs.QueryTrajectoryState, self._on_query)

    def start(self) -> None:
        self._server.start()
        # A burst of goals is answered faster than actionlib's result queue of 50 is sent: rospy would drop
        # the oldest results, and their clients would wait for ever.
        self._server.result_pub.impl.set_queue_size(RESULT_QUEUE)
        # Feedback is sent from the node's publishing thread: synchronously, without rospy's per-message yield.
        self._server.feedback_pub.impl.set_queue_size(None)
        time_out_stalled_subscribers(self._server.feedback_pub)

    def _on_query(self, request: Any) -> Any:
        """QueryTrajectoryState: answered by the simulation thread, as all work on the simulation."""
        answer = on_sim_thread(self._queue, lambda: self.core.query(request.time.to_sec()))
        if isinstance(answer, str):
            raise self._rospy.ServiceException(answer)
        return self._msgs.QueryTrajectoryStateResponse(
            name=list(self.joints),
            position=answer.positions.tolist(),
            velocity=answer.velocities.tolist(),
            acceleration=answer.accelerations.tolist(),
        )

    # -- called from the simulation thread ---------------------------------------------------
    def on_goal(self, handle: Any) -> None:
        goal = handle.get_goal()
        self.core.submit(trajectory_goal(goal.trajectory, goal), handle)

    def on_cancel(self, handle: Any) -> None:
        from actionlib_msgs.msg import GoalStatus

        goal_id = handle.get_goal_id().id
        self.core.cancel(lambda active: active.get_goal_id().id == goal_id)
        cancelable = (GoalStatus.PENDING, GoalStatus.ACTIVE, GoalStatus.RECALLING, GoalStatus.PREEMPTING)
        if handle.get_goal_status().status in cancelable:  # a finished goal stays as it ended
            handle.set_canceled(self._result(ErrorCode.SUCCESSFUL, "canceled"), "canceled")

    def on_command(self, msg: Any) -> None:
        self.core.command(trajectory_goal(msg))

    # -- the core's sink ---------------------------------------------------------------------
    def _result(self, code: int, text: str) -> Any:
        return self._msgs.FollowJointTrajectoryResult(error_code=int(code), error_string=text)

    def accepted(self, handle: Any) -> None:
        handle.set_accepted("")

    def rejected(self, handle: Any, rejection: Rejection) -> None:
        handle.set_rejected(self._result(rejection.code, rejection.reason), rejection.reason)

    def finished(self, handle: Any, result: Result) -> None:
        message = self._result(result.code, result.text)
        if result.status is Status.SUCCEEDED:
            handle.set_succeeded(message, result.text)
        elif result.status is Status.ABORTED:
            handle.set_aborted(message, result.text)
        else:
            handle.set_canceled(message, result.text)

    def warn(self, text: str) -> None:
        self._rospy.logwarn(text)

    def state(self, sample: Sample) -> None:
        self._send([(self._publish_state, sample)])  # the message is built on the publishing thread

    def _publish_state(self, sample: Sample) -> None:
        # One message, refilled: publishing serialises it before it returns (so does actionlib's feedback).
        message = self._state_message
        message.header.stamp = self._rospy.Time.from_sec(sample.stamp)
        message.joint_names = list(sample.joints)
        self._fill(message, sample)
        self._state.publish(message)

    def feedback(self, handle: Any, sample: Sample) -> None:
        self._send([(lambda s: handle.publish_feedback(self._feedback(s)), sample)])

    def _feedback(self, sample: Sample) -> Any:
        feedback = self._feedback_message
        feedback.header.stamp = self._rospy.Time.from_sec(sample.stamp)
        feedback.joint_names = list(sample.joints)
        self._fill(feedback, sample)
        return feedback

    @staticmethod
    def _fill(message: Any, sample: Sample) -> None:
        """desired, actual and error of a state or feedback message (fields not set stay empty)."""
        desired, actual, error = message.desired, message.actual, message.error
        desired.positions = sample.desired.positions.tolist()
        desired.velocities = sample.desired.velocities.tolist()
        desired.accelerations = sample.desired.accelerations.tolist()
        actual.positions = sample.actual_positions.tolist()
        actual.velocities = sample.actual_velocities.tolist()
        error.positions = sample.position_error.tolist()
        error.velocities = sample.velocity_error.tolist()
