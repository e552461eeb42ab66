"""The controller core with ros2_controllers' (Jazzy) semantics, on a real simulation and no ROS: what the ROS 2
adapter (svhdesc/ros2) relies on, beside the noetic defaults that tests/control/test_trajectory_core.py covers.

Seeded faults (each failed its test, then reverted): JAZZY with empty_goal_stops True -> the empty goal is accepted;
JAZZY.preempted_code SUCCESSFUL -> preemption code 0; zero_goal_time_waits ignored in _check_goal -> the goal aborts
with -5 at once; holds_unnamed False -> the unnamed joint goes on to its old target; check() skipping the running
test -> a stopped controller's goal passes the check; cancel holding only the canceled goal's joints -> the joint
the partial goal left out goes on to its kept command."""

from __future__ import annotations

from typing import Any

import pytest

from svhdesc.control.goals import ErrorCode, Rejection, Tolerances
from svhdesc.control.trajectory import JAZZY, Goal, JointTrajectoryCore, Result, Sample, Status
from svhdesc.sim import Point, Simulation


class Sink:
    def __init__(self) -> None:
        self.results: list[tuple[Any, Result]] = []
        self.events: list[tuple[str, Any]] = []
        self.warned: list[str] = []

    def accepted(self, handle: Any) -> None:
        self.events.append(("accepted", handle))

    def rejected(self, handle: Any, rejection: Rejection) -> None:
        self.events.append(("rejected", rejection))

    def finished(self, handle: Any, result: Result) -> None:
        self.results.append((handle, result))

    def feedback(self, handle: Any, sample: Sample) -> None: ...

    def state(self, sample: Sample) -> None: ...

    def warn(self, text: str) -> None:
        self.warned.append(text)


def jazzy_core(sim: Simulation) -> tuple[Simulation, JointTrajectoryCore, Sink]:
    """The hand's controller with Jazzy's semantics and unchecked tolerances, over ``sim``, reporting to a Sink."""
    sink = Sink()
    joints = list(sim.info.actuators)
    defaults = Tolerances({j: 0.0 for j in joints}, {j: 0.0 for j in joints}, 0.01, 0.0)
    core = JointTrajectoryCore("right_hand", joints, sim, sink, True, defaults, reports_velocity=False, semantics=JAZZY)
    return sim, core, sink


@pytest.fixture
def jazzy() -> tuple[Simulation, JointTrajectoryCore, Sink]:
    return jazzy_core(Simulation("svh_right", "home"))


def _run(sim: Simulation, core: JointTrajectoryCore, seconds: float) -> None:
    sim.run(seconds, realtime=False, every=0.008, callback=lambda _: core.update())


def test_an_empty_goal_is_rejected(jazzy: tuple[Simulation, JointTrajectoryCore, Sink]) -> None:
    """Jazzy's validate_trajectory_msg: "Empty trajectory received." (noetic: stop where it is)."""
    _, core, sink = jazzy
    goal = Goal(core.joints, [])
    assert core.check(goal) is not None
    rejection = core.submit(goal, "h")
    assert rejection is not None and rejection.code is ErrorCode.INVALID_GOAL
    assert sink.events == [("rejected", rejection)]


def test_preemption_cancels_with_invalid_goal(jazzy: tuple[Simulation, JointTrajectoryCore, Sink]) -> None:
    sim, core, sink = jazzy
    joint = core.joints[0]
    assert core.submit(Goal([joint], [Point(2.0, (0.5,))]), "first") is None
    _run(sim, core, 0.1)
    assert core.submit(Goal([joint], [Point(0.5, (0.1,))]), "second") is None
    assert sink.results[0] == (
        "first",
        Result(Status.CANCELED, ErrorCode.INVALID_GOAL, "Current goal cancelled due to new incoming action."),
    )


def test_goal_time_zero_waits_for_the_goal_tolerance(jazzy: tuple[Simulation, JointTrajectoryCore, Sink]) -> None:
    """A goal tolerance the joint reaches only after the end: with goal_time 0, Jazzy waits (noetic aborts with
    -5 at once)."""
    sim, core, sink = jazzy
    joint = core.joints[0]
    low, high = sim.limits(joint)
    target = low + 0.6 * (high - low)
    assert core.submit(Goal([joint], [Point(0.05, (target,))], goal_position={joint: 0.01}), "h") is None
    _run(sim, core, 0.2)
    assert sink.results == []  # past the end, not yet within 0.01 rad: still waiting
    _run(sim, core, 3.0)
    assert sink.results == [("h", Result(Status.SUCCEEDED, ErrorCode.SUCCESSFUL, ""))]


def test_a_partial_goal_stops_the_joints_it_leaves_out(jazzy: tuple[Simulation, JointTrajectoryCore, Sink]) -> None:
    """fill_partial_goal: the joints a new partial goal does not name keep their last command."""
    sim, core, sink = jazzy
    first, second = core.joints[0], core.joints[1]
    far = sim.limits(first)[1]
    assert core.submit(Goal([first], [Point(3.0, (far,))]), "a") is None
    _run(sim, core, 0.5)
    assert core.submit(Goal([second], [Point(0.3, (sim.desired([second]).positions[0],))]), "b") is None
    held = sim.desired([first]).positions[0]
    _run(sim, core, 1.0)
    assert sim.desired([first]).positions[0] == pytest.approx(held, abs=1e-9)
    assert held < far - 0.1


def test_a_canceled_partial_goal_holds_every_joint(jazzy: tuple[Simulation, JointTrajectoryCore, Sink]) -> None:
    """set_hold_position on cancel: every joint of the controller holds where it is, the one a partial goal left out
    (still closing on the command it kept) too. Deterministic here; over ROS 2 the cancel's instant is the node's."""
    sim, core, sink = jazzy
    first, second = core.joints[0], core.joints[1]
    assert core.submit(Goal([first], [Point(1.0, (sim.limits(first)[1],))]), "a") is None
    _run(sim, core, 0.5)
    assert core.submit(Goal([second], [Point(1.0, (sim.desired([second]).positions[0],))]), "b") is None
    kept = sim.desired([first]).positions[0]
    assert core.cancel(lambda handle: handle == "b")
    where = sim.positions()[first]
    assert abs(kept - where) > 1e-3  # still on its way: the case
    _run(sim, core, 0.5)
    assert sim.desired([first]).positions[0] == pytest.approx(where, abs=1e-9)


def test_a_stopped_controller_fails_the_check(jazzy: tuple[Simulation, JointTrajectoryCore, Sink]) -> None:
    sim, core, _ = jazzy
    core.stopping()
    rejection = core.check(Goal([core.joints[0]], [Point(1.0, (0.1,))]))
    assert rejection is not None and "not running" in rejection.reason
