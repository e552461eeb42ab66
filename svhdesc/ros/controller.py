"""One JointTrajectoryController: a FollowJointTrajectory action server and a ``command`` topic.

Semantics follow ros_control's joint_trajectory_controller: a goal is checked (INVALID_JOINTS,
INVALID_GOAL; INVALID_GOAL too while the controller is stopped) and rejected, or accepted and
preempts the active goal; the active goal aborts on a path tolerance violation (the joints then hold
where they are) or when the joints are not within the goal tolerances ``goal_time`` after the end
(at once when it is 0); cancel holds the current position. It publishes ``state``
(JointTrajectoryControllerState) and serves ``query_state`` (QueryTrajectoryState). ROS callbacks
only queue work; the simulation thread does it (see node.py).
"""

from __future__ import annotations

import threading
from collections import deque
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from svhdesc.errors import SvhdescError
from svhdesc.model import ACTION
from svhdesc.ros import goals as codes
from svhdesc.ros.goals import Tolerances, check_goal
from svhdesc.sim import Point, Simulation
from svhdesc.sim.trajectory import Trajectory


@dataclass
class _Active:
    handle: Any  # actionlib ServerGoalHandle
    joints: list[str]
    trajectory: Trajectory
    tolerances: Tolerances


def on_sim_thread(queue: deque, work: Callable[[], Any], timeout: float = 10.0) -> Any:
    """Run ``work`` on the simulation thread (which drains ``queue``) and wait for its value."""
    done = threading.Event()
    box: list[Any] = []

    def run(_: Any) -> None:
        try:
            box.append(work())
        finally:
            done.set()

    queue.append((run, None))
    if not done.wait(timeout) or not box:
        return "the simulation did not answer"
    return box[0]


def _duration(value: Any) -> float:
    return float(value.secs) + 1e-9 * float(value.nsecs)


def _points(trajectory_msg: Any) -> list[Point]:
    points = []
    for point in trajectory_msg.points:
        points.append(
            Point(
                _duration(point.time_from_start),
                tuple(point.positions),
                tuple(point.velocities) or None,
                tuple(point.accelerations) or None,
            )
        )
    return points


class TrajectoryController:
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
    ) -> None:
        """``send`` hands (callable, message) pairs to a publishing thread (default: call at once)."""
        import actionlib
        import rospy
        from trajectory_msgs.msg import JointTrajectory

        self.name = name
        self.joints = list(joints)
        self._sim = sim
        self._msgs = msgs
        self._rospy = rospy
        self._allow_partial = allow_partial
        self.defaults = defaults
        self._queue = queue
        self._active: _Active | None = None
        self._feedback_period = feedback_period  # JTC's action_monitor_rate: 20 Hz
        self._send = send or (lambda batch: [target(message) for target, message in batch])
        self._qpos = {j: int(sim.model.joint(j).qposadr[0]) for j in sim.info.joints}
        self._qvel = {j: int(sim.model.joint(j).dofadr[0]) for j in sim.info.joints}
        self._next_feedback = 0.0
        self._state_period = state_period  # JTC's state_publish_rate
        self._next_state = 0.0
        self.running = running
        # SCHUNK's SVHRosControlHWInterface never fills its joint velocities: its JTC sees 0 rad/s.
        self._reports_velocity = reports_velocity
        self._limits = {j: sim.limits(j) for j in self.joints}
        self._server = actionlib.ActionServer(
            f"{name}/{ACTION}",  # relative: a node started in a namespace serves there
            msgs.FollowJointTrajectoryAction,
            lambda handle: queue.append((self.on_goal, handle)),
            lambda handle: queue.append((self.on_cancel, handle)),
            auto_start=False,
        )
        self._command = rospy.Subscriber(
            f"{name}/command", JointTrajectory, lambda msg: queue.append((self.on_command, msg)), queue_size=1
        )
        self._state = rospy.Publisher(f"{name}/state", msgs.JointTrajectoryControllerState, queue_size=1)
        self._query = rospy.Service(f"{name}/query_state", msgs.QueryTrajectoryState, self._on_query)

    def start(self) -> None:
        self._server.start()

    # -- controller_manager switching (simulation thread) -------------------------------------
    def starting(self) -> None:
        """As JTC::starting: hold where the joints are."""
        self._sim.hold(self.joints)
        self.running = True

    def stopping(self) -> None:
        """As JTC::stopping: the active goal is canceled (preempted); the joints hold."""
        self._preempt("the controller was stopped")
        self._sim.hold(self.joints)
        self.running = False

    def _on_query(self, request: Any) -> Any:
        """QueryTrajectoryState: answered by the simulation thread, as all work on the simulation."""
        answer = on_sim_thread(self._queue, lambda: self._sample(request.time.to_sec()))
        if isinstance(answer, str):
            raise self._rospy.ServiceException(answer)
        return answer

    def _sample(self, when: float) -> Any:
        if not self.running:
            return f"{self.name}: Can't sample trajectory. Controller is not running."
        state = self._sim.desired(self.joints, when)
        return self._msgs.QueryTrajectoryStateResponse(
            name=list(self.joints),
            position=state.positions.tolist(),
            velocity=state.velocities.tolist(),
            acceleration=state.accelerations.tolist(),
        )

    # -- called from the simulation thread ---------------------------------------------------
    def _result(self, code: int, text: str) -> Any:
        return self._msgs.FollowJointTrajectoryResult(error_code=code, error_string=text)

    def _check(self, msg: Any) -> tuple[list[Point], codes.Rejection | None]:
        points = _points(msg)
        stamp = msg.header.stamp.to_sec()
        rejection = check_goal(
            msg.joint_names, points, stamp, self._sim.time, self.joints, self._allow_partial, self._limits
        )
        return points, rejection

    def _start(self, msg: Any, points: list[Point]) -> Trajectory:
        stamp = msg.header.stamp.to_sec()
        return self._sim.follow(list(msg.joint_names), points, None if stamp == 0.0 else stamp)

    def _preempt(self, why: str) -> None:
        if self._active is not None:
            self._active.handle.set_canceled(self._result(codes.SUCCESSFUL, why), why)
            self._active = None

    def on_goal(self, handle: Any) -> None:
        goal = handle.get_goal()
        if not self.running:
            reason = "Can't accept new action goals. Controller is not running."
            self._rospy.logwarn(f"{self.name}: goal rejected ({codes.INVALID_GOAL}): {reason}")
            handle.set_rejected(self._result(codes.INVALID_GOAL, reason), reason)
            return
        try:
            points, rejection = self._check(goal.trajectory)
        except (TypeError, ValueError, AttributeError) as exc:  # a malformed message
            points, rejection = [], codes.Rejection(codes.INVALID_GOAL, f"malformed goal: {exc}")
        if not points and (rejection is None or rejection.code == codes.INVALID_GOAL):
            # As JointTrajectoryController: valid joints and no points stop the controller where it is.
            self._preempt("preempted by an empty goal")
            self._sim.hold(self.joints)
            handle.set_accepted("")
            handle.set_succeeded(self._result(codes.SUCCESSFUL, "stopped: empty trajectory"), "stopped")
            return
        if rejection is None:
            try:
                trajectory = self._start(goal.trajectory, points)
            except SvhdescError as exc:
                rejection = codes.Rejection(codes.INVALID_GOAL, str(exc))
        if rejection is not None:
            self._rospy.logwarn(f"{self.name}: goal rejected ({rejection.code}): {rejection.reason}")
            handle.set_rejected(self._result(rejection.code, rejection.reason), rejection.reason)
            return
        self._preempt("preempted by a new goal")
        handle.set_accepted("")
        tolerances = self.defaults.merged(
            {t.name: t.position for t in goal.path_tolerance},
            {t.name: t.position for t in goal.goal_tolerance},
            _duration(goal.goal_time_tolerance),
            {t.name: t.velocity for t in goal.path_tolerance},
            {t.name: t.velocity for t in goal.goal_tolerance},
        )
        self._active = _Active(handle, list(goal.trajectory.joint_names), trajectory, tolerances)
        self._next_feedback = self._sim.time

    def on_cancel(self, handle: Any) -> None:
        from actionlib_msgs.msg import GoalStatus

        if self._active is not None and self._active.handle.get_goal_id().id == handle.get_goal_id().id:
            self._sim.hold(self._active.joints)
            self._active = None
        cancelable = (GoalStatus.PENDING, GoalStatus.ACTIVE, GoalStatus.RECALLING, GoalStatus.PREEMPTING)
        if handle.get_goal_status().status in cancelable:  # a finished goal stays as it ended
            handle.set_canceled(self._result(codes.SUCCESSFUL, "canceled"), "canceled")

    def on_command(self, msg: Any) -> None:
        if not self.running:
            self._rospy.logwarn(f"{self.name}/command: Can't accept new commands. Controller is not running.")
            return
        if not msg.points:  # an empty trajectory stops the controller where it is
            self._preempt("stopped by an empty command")
            self._sim.hold(self.joints)
            return
        try:
            points, rejection = self._check(msg)
            if rejection is None:
                self._start(msg, points)
        except (TypeError, ValueError, AttributeError, SvhdescError) as exc:
            rejection = codes.Rejection(codes.INVALID_GOAL, f"malformed command: {exc}")
        if rejection is not None:
            self._rospy.logwarn(f"{self.name}/command: trajectory ignored: {rejection.reason}")
            return
        self._preempt("preempted by a command")

    def update(self) -> None:
        """Publish the state, check the active goal's tolerances, send feedback (every control period)."""
        if not self.running:
            return
        sim = self._sim
        now = sim.time
        if now >= self._next_state:
            self._publish_state(now)
            self._next_state = now + self._state_period
        active = self._active
        if active is None:
            return
        desired = sim.desired(active.joints, now)
        actual = sim.data.qpos[[self._qpos[j] for j in active.joints]].copy()
        actual_velocity = self._velocities(active.joints)
        error = desired.positions - actual
        velocity_error = desired.velocities - actual_velocity
        if now >= self._next_feedback:
            self._feedback(active, desired, actual, actual_velocity)
            self._next_feedback = now + self._feedback_period
        tolerances = active.tolerances
        if now < active.trajectory.end_time:
            for joint, e, ev in zip(active.joints, error, velocity_error):
                limit = tolerances.path.get(joint, 0.0)
                vlimit = tolerances.path_velocity.get(joint, 0.0)
                if (limit > 0 and abs(e) > limit) or (vlimit > 0 and abs(ev) > vlimit):
                    self._finish(
                        codes.PATH_TOLERANCE_VIOLATED,
                        f"{joint} is {abs(e):.4f} rad, {abs(ev):.4f} rad/s off its path "
                        f"(tolerances {limit} rad, {vlimit} rad/s)",
                        hold=True,
                    )
                    return
            return
        final = active.trajectory.final_positions
        columns = [active.trajectory.joints.index(j) for j in active.joints]
        off = {j: abs(final[c] - a) for j, c, a in zip(active.joints, columns, actual)}
        speed = {j: abs(v) for j, v in zip(active.joints, actual_velocity)}

        def outside(joint: str) -> bool:
            position, velocity = tolerances.goal.get(joint, 0.0), tolerances.goal_velocity.get(joint, 0.0)
            return (position > 0 and off[joint] > position) or (velocity > 0 and speed[joint] > velocity)

        failing = [j for j in active.joints if outside(j)]
        if not failing:
            self._finish(codes.SUCCESSFUL, "")
        elif now >= active.trajectory.end_time + tolerances.goal_time:  # JTC: at once when goal_time is 0
            worst = failing[0]
            self._finish(
                codes.GOAL_TOLERANCE_VIOLATED,
                f"{worst} is {off[worst]:.4f} rad from its goal moving at {speed[worst]:.4f} rad/s "
                f"{tolerances.goal_time} s after the end (tolerances {tolerances.goal.get(worst, 0.0)} rad, "
                f"{tolerances.goal_velocity.get(worst, 0.0)} rad/s)",
            )

    def _velocities(self, joints: Sequence[str]) -> np.ndarray:
        """The joint velocities the real driver's hardware interface hands the controller."""
        if not self._reports_velocity:
            return np.zeros(len(joints))
        return self._sim.data.qvel[[self._qvel[j] for j in joints]].copy()

    def _publish_state(self, now: float) -> None:
        sim = self._sim
        desired = sim.desired(self.joints, now)
        actual = sim.data.qpos[[self._qpos[j] for j in self.joints]].copy()
        velocity = self._velocities(self.joints)
        message = self._msgs.JointTrajectoryControllerState()
        message.header.stamp = self._rospy.Time.from_sec(now)
        message.joint_names = list(self.joints)
        self._fill(message, desired, actual, velocity)
        self._send([(self._state, message)])

    @staticmethod
    def _fill(message: Any, desired: Any, actual: np.ndarray, velocity: np.ndarray) -> None:
        from trajectory_msgs.msg import JointTrajectoryPoint

        message.desired = JointTrajectoryPoint(
            positions=desired.positions.tolist(),
            velocities=desired.velocities.tolist(),
            accelerations=desired.accelerations.tolist(),
        )
        message.actual = JointTrajectoryPoint(positions=actual.tolist(), velocities=velocity.tolist())
        message.error = JointTrajectoryPoint(
            positions=(desired.positions - actual).tolist(), velocities=(desired.velocities - velocity).tolist()
        )

    def _finish(self, code: int, text: str, hold: bool = False) -> None:
        active = self._active
        assert active is not None
        self._active = None
        if hold:
            self._sim.hold(active.joints)
        if code == codes.SUCCESSFUL:
            active.handle.set_succeeded(self._result(code, text), text)
        else:
            self._rospy.logwarn(f"{self.name}: goal aborted ({code}): {text}")
            active.handle.set_aborted(self._result(code, text), text)

    def _feedback(self, active: _Active, desired: Any, actual: np.ndarray, velocity: np.ndarray) -> None:
        feedback = self._msgs.FollowJointTrajectoryFeedback()
        feedback.header.stamp = self._rospy.Time.from_sec(self._sim.time)
        feedback.joint_names = active.joints
        self._fill(feedback, desired, actual, velocity)
        self._send([(active.handle.publish_feedback, feedback)])
