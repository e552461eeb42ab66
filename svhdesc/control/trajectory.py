"""ros_controllers' JointTrajectoryController on plain values: goal checks, preemption, cancel,
tolerances, feedback and state, with no transport.

A goal is checked (INVALID_JOINTS, INVALID_GOAL; INVALID_GOAL too while the controller is stopped) and
rejected, or accepted and preempts the active goal; the active goal aborts on a path tolerance violation
(the joints then hold where they are) or when the joints are not within the goal tolerances ``goal_time``
after the end (at once when it is 0); cancel holds the current position. Every call happens on the
simulation thread; an adapter (ROS 1: svhdesc.ros1.controller, ROS 2: svhdesc.ros2.controller) turns messages
into ``Goal`` values and what the core reports to its ``Sink`` back into messages.

No transport, no simulator import: the core reads the time and the joints and commands the servos through
``Hardware`` (svhdesc.sim.Simulation is one), as ros_control's JTC works through its hardware interface.
"""

from __future__ import annotations

import enum
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field, replace
from typing import Any, Protocol

import numpy as np

from svhdesc.control.goals import ErrorCode, Rejection, Tolerances, check_goal
from svhdesc.control.spline import Point, State, Trajectory
from svhdesc.errors import SvhdescError

FLOAT_EPSILON = float(np.finfo(np.float32).eps)  # std::numeric_limits<float>::epsilon(), as Jazzy's JTC compares


@dataclass(frozen=True)
class Goal:
    """A FollowJointTrajectory goal (or a ``command`` trajectory): ``stamp`` 0 starts it now; tolerances
    map joint names to the goal's values (0: the controller's default, negative: unchecked)."""

    joint_names: list[str]
    points: list[Point]
    stamp: float = 0.0
    path_position: Mapping[str, float] = field(default_factory=dict)
    path_velocity: Mapping[str, float] = field(default_factory=dict)
    goal_position: Mapping[str, float] = field(default_factory=dict)
    goal_velocity: Mapping[str, float] = field(default_factory=dict)
    goal_time: float = 0.0


@dataclass(frozen=True)
class Semantics:
    """Where ros_controllers' (noetic) and ros2_controllers' (Jazzy) joint_trajectory_controller differ.

    Jazzy (ros2_controllers joint_trajectory_controller.cpp): validate_trajectory_msg rejects an empty
    trajectory ("Empty trajectory received."); with ``constraints.goal_time`` 0 the controller waits for the
    goal tolerances indefinitely; preempt_active_goal cancels the old goal with INVALID_GOAL and "Current goal
    cancelled due to new incoming action."; fill_partial_goal gives the joints a partial goal does not name
    their last command (they stop)."""

    empty_goal_stops: bool
    zero_goal_time_waits: bool
    preempted_code: ErrorCode
    preempted_text: str
    holds_unnamed: bool
    rejects_moving_end: bool = False  # allow_nonzero_velocity_at_trajectory_end false (Jazzy's default)


NOETIC = Semantics(True, False, ErrorCode.SUCCESSFUL, "preempted by a new goal", False)
JAZZY = Semantics(False, True, ErrorCode.INVALID_GOAL, "Current goal cancelled due to new incoming action.", True, True)


class Status(enum.Enum):
    SUCCEEDED = "succeeded"
    ABORTED = "aborted"
    CANCELED = "canceled"  # canceled by the client, or preempted by a newer goal / a stop


@dataclass(frozen=True)
class Result:
    status: Status
    code: ErrorCode
    text: str


@dataclass(frozen=True)
class Sample:
    """What ``state`` and the action's feedback carry: desired, actual and their difference."""

    stamp: float
    joints: list[str]
    desired: State
    actual_positions: np.ndarray
    actual_velocities: np.ndarray

    @property
    def position_error(self) -> np.ndarray:
        return self.desired.positions - self.actual_positions

    @property
    def velocity_error(self) -> np.ndarray:
        return self.desired.velocities - self.actual_velocities


class Hardware(Protocol):
    """What the controller needs of the robot it runs on: the clock, its joints' state and range, and position
    servos that follow a spline between updates (``follow``) or hold where the joints are."""

    @property
    def time(self) -> float: ...
    @property
    def timestep(self) -> float: ...  # s: "due" means within half of it
    def limits(self, name: str) -> tuple[float, float]: ...
    def joint_values(self, names: Sequence[str]) -> tuple[np.ndarray, np.ndarray]: ...  # positions, velocities
    def desired(self, names: Sequence[str], at: float | None = None) -> State: ...
    def follow(self, names: Sequence[str], points: Sequence[Point], start_time: float | None = None) -> Trajectory: ...
    def hold(self, names: Sequence[str]) -> None: ...
    def set_targets(self, targets: Mapping[str, float]) -> None: ...


class Sink(Protocol):
    """What a transport does with the core's decisions (``handle`` is the transport's goal handle)."""

    def accepted(self, handle: Any) -> None: ...
    def rejected(self, handle: Any, rejection: Rejection) -> None: ...
    def finished(self, handle: Any, result: Result) -> None: ...
    def feedback(self, handle: Any, sample: Sample) -> None: ...
    def state(self, sample: Sample) -> None: ...
    def warn(self, text: str) -> None: ...


@dataclass
class _Active:
    handle: Any
    joints: list[str]
    trajectory: Trajectory
    tolerances: Tolerances


def first_occurrences(goal: Goal | Rejection, joints: int) -> Goal | Rejection:
    """A goal naming a joint twice as JTC reads it: its permutation maps each controller joint to the
    first occurrence of the name, so later columns are ignored. A goal naming more joints than the controller's
    ``joints`` is rejected with INVALID_JOINTS: noetic's goalCB finds no mapping then (internal::mapping refuses a
    longer list) and answers "Joints on incoming goal don't match the controller joints."."""
    if isinstance(goal, Rejection):
        return goal
    if len(goal.joint_names) > joints:
        return Rejection(
            ErrorCode.INVALID_JOINTS,
            f"Joints on incoming goal don't match the controller joints: {len(goal.joint_names)} names for "
            f"{joints} joints ({list(goal.joint_names)})",
        )
    if len(set(goal.joint_names)) == len(goal.joint_names):
        return goal
    names = list(goal.joint_names)
    keep = [i for i, name in enumerate(names) if names.index(name) == i]

    def pick(values: Sequence[float] | None) -> tuple[float, ...] | None:
        if not values or len(values) != len(names):
            return values if not values else tuple(values)  # a size error stays for the check
        return tuple(values[i] for i in keep)

    points = [Point(p.time, pick(p.positions) or (), pick(p.velocities), pick(p.accelerations)) for p in goal.points]
    return replace(goal, joint_names=[names[i] for i in keep], points=points)


def moving_end(goal: Goal) -> Rejection | None:
    """Jazzy's validate_trajectory_msg with allow_nonzero_velocity_at_trajectory_end false (its default): the last
    point's velocities, where given, must be zero (within float's epsilon)."""
    last = goal.points[-1]
    for name, velocity in zip(goal.joint_names, last.velocities or ()):
        if abs(velocity) > FLOAT_EPSILON:
            text = f"Velocity of last trajectory point of joint {name} is not zero: {velocity:.15f}"
            return Rejection(ErrorCode.INVALID_GOAL, text)
    return None


def due(now: float, when: float, timestep: float) -> bool:
    """Due within half a physics step: 0.02 s of steps never lands exactly on 0.02 in floating point."""
    return now >= when - 0.5 * timestep


def next_tick(due: float, period: float, now: float) -> float:
    """The next instant on the fixed grid ``due + k * period`` (exact rates: not ``now + period``, which
    loses a tick to rounding); after a pause (a stopped controller) the grid restarts at now."""
    following = due + period
    return following if following > now else now + period


class JointTrajectoryCore:
    def __init__(
        self,
        name: str,
        joints: Sequence[str],
        hardware: Hardware,
        sink: Sink,
        allow_partial: bool,
        defaults: Tolerances,
        feedback_period: float = 0.05,
        state_period: float = 0.02,
        running: bool = True,
        reports_velocity: bool = True,
        semantics: Semantics = NOETIC,
        update_period: float = 0.0,
    ) -> None:
        """``update_period``: the controller's own loop (0: every ``update`` call is an update); calls between
        its instants do nothing, so a transport may call it more often than it runs."""
        self.name = name
        self.semantics = semantics
        self.joints = list(joints)
        self.sink = sink
        self.defaults = defaults
        self.running = running
        self._hw = hardware
        self._allow_partial = allow_partial
        self._active: _Active | None = None
        self.feedback_period = feedback_period  # JTC's action_monitor_rate: 20 Hz
        self.state_period = state_period  # JTC's state_publish_rate
        self._next_feedback = 0.0
        self._next_state = 0.0
        self.update_period = update_period
        self._next_update = 0.0
        # SCHUNK's SVHRosControlHWInterface never fills its joint velocities: its JTC sees 0 rad/s.
        self._reports_velocity = reports_velocity
        self._limits = {j: hardware.limits(j) for j in self.joints}
        self._column = {j: k for k, j in enumerate(self.joints)}
        self._since = hardware.time  # when the current hold began (query_state before it fails)
        self._trajectory: Trajectory | None = None  # what the joints follow (Jazzy's current_trajectory_); None: a hold

    @property
    def active_handle(self) -> Any:
        return None if self._active is None else self._active.handle

    # -- controller_manager switching ---------------------------------------------------------
    def starting(self) -> None:
        """As JTC::starting: hold where the joints are."""
        self._hw.hold(self.joints)
        self._since = self._hw.time
        self._trajectory = None
        self.running = True

    def stopping(self) -> None:
        """As JTC::stopping: the active goal is canceled (preempted); the joints hold."""
        self._preempt("the controller was stopped")
        self._hw.hold(self.joints)
        self._trajectory = None
        self.running = False

    # -- goals, commands, cancel, queries -----------------------------------------------------
    def _check(self, goal: Goal) -> Rejection | None:
        try:
            if len(set(goal.joint_names)) != len(goal.joint_names):
                return Rejection(ErrorCode.INVALID_JOINTS, "internal: repeated names reach the check")
            rejection = check_goal(
                goal.joint_names,
                goal.points,
                goal.stamp,
                self._hw.time,
                self.joints,
                self._allow_partial,
                self._limits,
            )
            if rejection is None and self.semantics.rejects_moving_end:
                return moving_end(goal)
            return rejection
        except (TypeError, ValueError, AttributeError) as exc:  # a malformed message
            return Rejection(ErrorCode.INVALID_GOAL, f"malformed goal: {exc}")

    def _start(self, goal: Goal) -> Trajectory | Rejection:
        try:
            trajectory = self._hw.follow(list(goal.joint_names), goal.points, None if goal.stamp == 0.0 else goal.stamp)
        except (SvhdescError, TypeError, ValueError) as exc:
            return Rejection(ErrorCode.INVALID_GOAL, str(exc))
        self._trajectory = trajectory
        return trajectory

    def _preempt(self, why: str, code: ErrorCode = ErrorCode.SUCCESSFUL) -> None:
        if self._active is not None:
            handle, self._active = self._active.handle, None
            self.sink.finished(handle, Result(Status.CANCELED, code, why))

    def check(self, goal: Goal | Rejection) -> Rejection | None:
        """Read-only: why ``goal`` would be rejected now (an adapter whose transport answers a goal at once,
        as rclpy's goal callback, asks this first; ``submit`` checks again on the simulation thread)."""
        if not self.running:
            return Rejection(ErrorCode.INVALID_GOAL, "Can't accept new action goals. Controller is not running.")
        goal = first_occurrences(goal, len(self.joints))
        if isinstance(goal, Rejection):
            return goal
        if not goal.points and self.semantics.empty_goal_stops:
            return None
        return self._check(goal)

    def submit(self, goal: Goal | Rejection, handle: Any) -> Rejection | None:
        """A FollowJointTrajectory goal (or the adapter's rejection of a message it could not read): the
        sink hears accepted/rejected (and the result of a goal that ends at once); None when accepted."""
        if not self.running:
            return self._reject(
                handle, Rejection(ErrorCode.INVALID_GOAL, "Can't accept new action goals. Controller is not running.")
            )
        goal = first_occurrences(goal, len(self.joints))
        rejection = goal if isinstance(goal, Rejection) else self._check(goal)
        if (
            isinstance(goal, Goal)
            and not goal.points
            and self.semantics.empty_goal_stops
            and (rejection is None or rejection.code == ErrorCode.INVALID_GOAL)
        ):
            # As JointTrajectoryController: valid joints and no points stop the controller where it is.
            self._preempt("preempted by an empty goal")
            self._hw.hold(self.joints)
            self._trajectory = None
            self.sink.accepted(handle)
            self.sink.finished(handle, Result(Status.SUCCEEDED, ErrorCode.SUCCESSFUL, "stopped: empty trajectory"))
            return None
        if rejection is not None:
            return self._reject(handle, rejection)
        assert isinstance(goal, Goal)
        trajectory = self._start(goal)
        if isinstance(trajectory, Rejection):
            return self._reject(handle, trajectory)
        self._preempt(self.semantics.preempted_text, self.semantics.preempted_code)
        if self.semantics.holds_unnamed:
            self._hold_unnamed(goal.joint_names)
        self.sink.accepted(handle)
        tolerances = self.defaults.merged(
            goal.path_position, goal.goal_position, goal.goal_time, goal.path_velocity, goal.goal_velocity
        )
        self._active = _Active(handle, list(goal.joint_names), trajectory, tolerances)
        self._next_feedback = self._hw.time
        return None

    def _hold_unnamed(self, named: Sequence[str]) -> None:
        """Jazzy's fill_partial_goal: joints a partial goal leaves out keep their last command."""
        unnamed = [j for j in self.joints if j not in named]
        if unnamed:
            desired = self._hw.desired(unnamed)
            self._hw.set_targets(dict(zip(unnamed, desired.positions.tolist())))

    def _reject(self, handle: Any, rejection: Rejection) -> Rejection:
        self.sink.warn(f"{self.name}: goal rejected ({int(rejection.code)}): {rejection.reason}")
        self.sink.rejected(handle, rejection)
        return rejection

    def cancel(self, is_it: Callable[[Any], bool]) -> bool:
        """A client's cancel: True when ``is_it`` says the active goal's handle is the canceled goal (the
        joints then hold); the adapter answers canceled for any goal still pending or active."""
        if self._active is None or not is_it(self._active.handle):
            return False
        # Every joint of the controller, not only the goal's: JTC's setHoldPosition (noetic) / set_hold_position
        # (Jazzy) hold all of them where they are; the joints a partial goal left out may still be on their way.
        self._hw.hold(self.joints)
        self._trajectory = None
        self._active = None
        return True

    def command(self, goal: Goal | Rejection) -> Rejection | None:
        """The ``command`` topic: a trajectory without a goal handle; an empty one stops where it is."""
        if not self.running:
            self.sink.warn(f"{self.name}/command: Can't accept new commands. Controller is not running.")
            return Rejection(ErrorCode.INVALID_GOAL, "not running")
        goal = first_occurrences(goal, len(self.joints))
        if isinstance(goal, Goal) and not goal.points:
            self._preempt("stopped by an empty command")
            self._hw.hold(self.joints)
            self._trajectory = None
            return None
        rejection = goal if isinstance(goal, Rejection) else self._check(goal)
        if rejection is None:
            started = self._start(goal)  # type: ignore[arg-type]
            rejection = started if isinstance(started, Rejection) else None
        if rejection is not None:
            self.sink.warn(f"{self.name}/command: trajectory ignored: {rejection.reason}")
            return rejection
        self._preempt("preempted by a command")
        return None

    def topic(self, goal: Goal | Rejection) -> Rejection | None:
        """Jazzy JTC's ``~/joint_trajectory`` (topic_callback, then update): checked as a goal is; a valid trajectory
        replaces the one the joints follow (the joints it leaves out keep their last command, fill_partial_goal). An
        active goal is not ended: Jazzy's update() goes on judging it (tolerances, feedback, success) against the
        trajectory the topic brought. An inactive controller ignores the topic (subscriber_is_active_ false)."""
        if not self.running:
            return Rejection(ErrorCode.INVALID_GOAL, "the controller is not active: the trajectory is ignored")
        goal = first_occurrences(goal, len(self.joints))
        rejection = goal if isinstance(goal, Rejection) else self._check(goal)
        started = self._start(goal) if isinstance(goal, Goal) and rejection is None else rejection
        if isinstance(started, Rejection) or not isinstance(goal, Goal):
            rejection = started if isinstance(started, Rejection) else rejection
            assert rejection is not None
            self.sink.warn(f"{self.name}/joint_trajectory: trajectory rejected: {rejection.reason}")
            return rejection
        assert started is not None
        self._hold_unnamed(goal.joint_names)
        if self._active is not None:
            self._active.trajectory = started
            self._active.joints = list(goal.joint_names)
        return None

    def sample_current(self, when: float) -> tuple[State | None, str]:
        """Jazzy's ~/query_state: the desired state of every joint at ``when`` while the current trajectory runs;
        else None and why (inactive, holding, before its start, at or after its end)."""
        if not self.running:
            return None, "Can't sample trajectory. Controller is not active."
        trajectory = self._trajectory
        if trajectory is None:
            return None, "Currently there is no valid trajectory instance."
        if when < trajectory.begin_time:
            return None, "Requested sample time is earlier than the current trajectory start time."
        if when >= trajectory.end_time:
            return None, "Requested sample time precedes the current trajectory end time."
        return self._hw.desired(self.joints, when), ""

    def query(self, when: float) -> State | str:
        """QueryTrajectoryState: the desired state at ``when``, or why it cannot be sampled."""
        if not self.running:
            return f"{self.name}: Can't sample trajectory. Controller is not running."
        begin = self._since if self._active is None else self._active.trajectory.begin_time
        if when < begin:  # JTC: the time precedes its trajectory (a hold starts when the controller starts)
            return f"{self.name}: Requested sample time precedes trajectory start time."
        return self._hw.desired(self.joints, when)

    # -- every control period ----------------------------------------------------------------
    def sample(self, joints: Sequence[str], now: float) -> Sample:
        desired = self._hw.desired(joints, now)
        positions, velocities = self._hw.joint_values(joints)
        velocities = velocities if self._reports_velocity else np.zeros(len(joints))
        return Sample(now, list(joints), desired, positions, velocities)

    def _subset(self, full: Sample, joints: Sequence[str]) -> Sample:
        if joints == full.joints:
            return full
        k = [self._column[j] for j in joints]
        desired = State(full.desired.positions[k], full.desired.velocities[k], full.desired.accelerations[k])
        return Sample(full.stamp, list(joints), desired, full.actual_positions[k], full.actual_velocities[k])

    def update(self) -> None:
        """Publish the state, check the active goal's tolerances, send feedback (every control period). The
        controller's joints are sampled once; the goal's are a subset of that sample."""
        if not self.running:
            return
        now = self._hw.time
        timestep = self._hw.timestep
        if self.update_period > 0.0:
            if not due(now, self._next_update, timestep):
                return
            self._next_update = next_tick(self._next_update, self.update_period, now)
        active = self._active
        state_due = due(now, self._next_state, timestep)
        if not state_due and active is None:
            return
        full = self.sample(self.joints, now)
        if state_due:
            self.sink.state(full)
            self._next_state = next_tick(self._next_state, self.state_period, now)
        if active is None:
            return
        if due(now, self._next_feedback, timestep):
            # JTC's feedback names every joint of the controller, also for a partial goal.
            self.sink.feedback(active.handle, full)
            self._next_feedback = next_tick(self._next_feedback, self.feedback_period, now)
        sample = self._subset(full, active.joints)
        if now < active.trajectory.end_time:
            self._check_path(active, sample)
        else:
            self._check_goal(active, sample, now)

    def _check_path(self, active: _Active, sample: Sample) -> None:
        tolerances = active.tolerances
        for joint, e, ev in zip(active.joints, sample.position_error, sample.velocity_error):
            limit = tolerances.path.get(joint, 0.0)
            vlimit = tolerances.path_velocity.get(joint, 0.0)
            if (limit > 0 and abs(e) > limit) or (vlimit > 0 and abs(ev) > vlimit):
                self._finish(
                    ErrorCode.PATH_TOLERANCE_VIOLATED,
                    f"{joint} is {abs(e):.4f} rad, {abs(ev):.4f} rad/s off its path "
                    f"(tolerances {limit} rad, {vlimit} rad/s)",
                    hold=True,
                )
                return

    def _check_goal(self, active: _Active, sample: Sample, now: float) -> None:
        tolerances = active.tolerances
        final = active.trajectory.final_positions
        columns = [active.trajectory.joints.index(j) for j in active.joints]
        off = {j: abs(final[c] - a) for j, c, a in zip(active.joints, columns, sample.actual_positions)}
        speed = {j: abs(v) for j, v in zip(active.joints, sample.actual_velocities)}

        def outside(joint: str) -> bool:
            position, velocity = tolerances.goal.get(joint, 0.0), tolerances.goal_velocity.get(joint, 0.0)
            return (position > 0 and off[joint] > position) or (velocity > 0 and speed[joint] > velocity)

        failing = [j for j in active.joints if outside(j)]
        if not failing:
            self._finish(ErrorCode.SUCCESSFUL, "")
        elif tolerances.goal_time == 0.0 and self.semantics.zero_goal_time_waits:
            return  # Jazzy: goal_time 0 waits for the goal tolerances indefinitely
        elif now >= active.trajectory.end_time + tolerances.goal_time:  # noetic: at once when goal_time is 0
            worst = failing[0]
            self._finish(
                ErrorCode.GOAL_TOLERANCE_VIOLATED,
                f"{worst} is {off[worst]:.4f} rad from its goal moving at {speed[worst]:.4f} rad/s "
                f"{tolerances.goal_time} s after the end (tolerances {tolerances.goal.get(worst, 0.0)} rad, "
                f"{tolerances.goal_velocity.get(worst, 0.0)} rad/s)",
            )

    def _finish(self, code: ErrorCode, text: str, hold: bool = False) -> None:
        active = self._active
        assert active is not None
        self._active = None
        if hold:
            self._hw.hold(self.joints)  # as a cancel: every joint of the controller
            self._trajectory = None
        if code == ErrorCode.SUCCESSFUL:
            self.sink.finished(active.handle, Result(Status.SUCCEEDED, code, text))
        else:
            self.sink.warn(f"{self.name}: goal aborted ({int(code)}): {text}")
            self.sink.finished(active.handle, Result(Status.ABORTED, code, text))


class ForwardsToCore:
    """The controller-manager calls every transport's controller forwards to its transport-free core (a
    JointTrajectoryCore, or control.forward's ForwardCommandCore)."""

    core: Any

    @property
    def running(self) -> bool:
        return self.core.running

    def starting(self) -> None:
        self.core.starting()

    def stopping(self) -> None:
        self.core.stopping()

    def update(self) -> None:
        self.core.update()
