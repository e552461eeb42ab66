"""The transport-free JointTrajectoryController core on a real simulation, with no ROS at all."""

from __future__ import annotations

from typing import Any

import pytest

from svhdesc.control.goals import ErrorCode, Rejection, Tolerances
from svhdesc.control.trajectory import Goal, JointTrajectoryCore, Result, Sample, Status
from svhdesc.sim import Point, Simulation


class Recorder:
    """A Sink that keeps what the core reported."""

    def __init__(self) -> None:
        self.states: list[Sample] = []
        self.feedbacks: list[Sample] = []
        self.results: list[tuple[Any, Result]] = []
        self.events: list[tuple[str, Any]] = []

    def accepted(self, handle: Any) -> None:
        self.events.append(("accepted", handle))

    def rejected(self, handle: Any, rejection: Rejection) -> None:
        self.events.append(("rejected", rejection))

    def finished(self, handle: Any, result: Result) -> None:
        self.results.append((handle, result))

    def feedback(self, handle: Any, sample: Sample) -> None:
        self.feedbacks.append(sample)

    def state(self, sample: Sample) -> None:
        self.states.append(sample)

    def warn(self, text: str) -> None:
        self.events.append(("warn", text))


@pytest.fixture
def core() -> tuple[Simulation, JointTrajectoryCore, Recorder]:
    sim = Simulation("svh_right", "home")
    sink = Recorder()
    joints = list(sim.info.actuators)
    defaults = Tolerances({j: 0.0 for j in joints}, {j: 0.0 for j in joints}, 0.0, 0.0)
    return sim, JointTrajectoryCore("hand", joints, sim, sink, True, defaults), sink


def _run(sim: Simulation, core: JointTrajectoryCore, seconds: float) -> None:
    sim.run(seconds, realtime=False, every=0.001, callback=lambda _: core.update())


def test_state_comes_at_exactly_its_rate(core: tuple[Simulation, JointTrajectoryCore, Recorder]) -> None:
    """Seeded fault: ``now >= next`` then ``next = now + period`` (the former rule) loses ticks to
    rounding: fewer than 50 states a second."""
    sim, controller, sink = core
    _run(sim, controller, 2.0)
    stamps = [s.stamp for s in sink.states]
    assert len(stamps) == pytest.approx(100, abs=1)
    assert max(b - a for a, b in zip(stamps, stamps[1:])) < 0.02 + sim.timestep


def test_partial_goal_feedback_names_every_joint(core: tuple[Simulation, JointTrajectoryCore, Recorder]) -> None:
    """Seeded fault: feedback sampled over the goal's joints only (the former behaviour)."""
    sim, controller, sink = core
    joint = controller.joints[-1]
    here = sim.desired([joint]).positions[0]
    assert controller.submit(Goal([joint], [Point(0.3, (here,))]), "h1") is None
    _run(sim, controller, 0.5)
    assert sink.events[0] == ("accepted", "h1") and sink.feedbacks
    assert all(s.joints == controller.joints for s in sink.feedbacks)
    assert sink.results == [("h1", Result(Status.SUCCEEDED, ErrorCode.SUCCESSFUL, ""))]


def test_unknown_joint_is_rejected_with_invalid_joints(core: tuple[Simulation, JointTrajectoryCore, Recorder]) -> None:
    sim, controller, sink = core
    rejection = controller.submit(Goal(["no_such_joint"], [Point(1.0, (0.0,))]), "h")
    assert rejection is not None and rejection.code is ErrorCode.INVALID_JOINTS and int(rejection.code) == -2
    assert sink.events[-1] == ("rejected", rejection)


def test_a_repeated_joint_is_accepted_and_its_first_column_wins(
    core: tuple[Simulation, JointTrajectoryCore, Recorder],
) -> None:
    """As noetic's JTC (its permutation takes a name's first occurrence). Seeded fault: the former
    INVALID_JOINTS rejection of repeated names."""
    sim, controller, sink = core
    joint = controller.joints[-1]
    low, high = sim.limits(joint)
    first, second = low + 0.6 * (high - low), low + 0.2 * (high - low)
    assert controller.submit(Goal([joint, joint], [Point(0.3, (first, second))]), "h") is None
    _run(sim, controller, 0.4)
    assert sim.desired([joint]).positions[0] == pytest.approx(first)


def test_more_names_than_joints_are_invalid_joints(core: tuple[Simulation, JointTrajectoryCore, Recorder]) -> None:
    """Issue 39: every channel and one of them again (10 names for 9 joints) is INVALID_JOINTS, as noetic's goalCB
    (its mapping refuses a list longer than the controller's), also on the command topic. Seeded fault: the check
    removed from first_occurrences -> accepted."""
    sim, controller, sink = core
    names = [*controller.joints, controller.joints[0]]
    here = [float(v) for v in sim.desired(names).positions]
    rejection = controller.submit(Goal(names, [Point(0.5, tuple(here))]), "h")
    assert rejection is not None and rejection.code is ErrorCode.INVALID_JOINTS, rejection
    assert "don't match the controller joints" in rejection.reason
    assert controller.command(Goal(names, [Point(0.5, tuple(here))])) is not None


def test_query_before_the_trajectory_start_fails(core: tuple[Simulation, JointTrajectoryCore, Recorder]) -> None:
    """As JTC's query_state: a time before the current trajectory (or hold) began is refused. Seeded
    fault: the former query answered any time."""
    sim, controller, _ = core
    _run(sim, controller, 0.2)
    joint = controller.joints[-1]
    here = sim.desired([joint]).positions[0]
    assert controller.submit(Goal([joint], [Point(0.5, (here,))]), "h") is None
    assert isinstance(controller.query(sim.time - 0.1), str)
    assert not isinstance(controller.query(sim.time + 0.1), str)
