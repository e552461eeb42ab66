"""Jazzy JTC's ``~/joint_trajectory`` and ``~/query_state`` on the transport-free core (JointTrajectoryCore.topic,
sample_current), on a real simulation and no ROS: what the ROS 2 adapter's topic relies on
(tests/ros2/test_driver_interfaces.py runs it over ROS 2).

Seeded faults (each failed its test here, then reverted): topic() preempting the active goal -> the goal is
canceled; topic() skipping _hold_unnamed -> the unnamed joint goes on to its old target; rejects_moving_end False in
JAZZY -> the moving end is accepted; topic() skipping the check -> the moving end and the nameless trajectory
are taken (NaN, unknown joints, times and sizes the simulation's follow() refuses again); sample_current without the
end test -> success after the end."""

from __future__ import annotations

import math

import pytest

from svhdesc.control.goals import ErrorCode, Rejection
from svhdesc.control.trajectory import Goal, JointTrajectoryCore, Result, Status
from svhdesc.sim import Point, Simulation
from tests.control.test_jazzy_semantics import Sink, _run, jazzy_core


@pytest.fixture(scope="module")
def sim() -> Simulation:
    return Simulation("svh_right", "home")


@pytest.fixture
def jazzy(sim: Simulation) -> tuple[Simulation, JointTrajectoryCore, Sink]:
    sim.reset("home")
    return jazzy_core(sim)


def _mid(sim: Simulation, joint: str, fraction: float) -> float:
    low, high = sim.limits(joint)
    return low + fraction * (high - low)


def test_a_topic_trajectory_replaces_the_running_one(jazzy: tuple[Simulation, JointTrajectoryCore, Sink]) -> None:
    sim, core, _ = jazzy
    joint = core.joints[0]
    assert core.topic(Goal([joint], [Point(3.0, (_mid(sim, joint, 0.9),))])) is None
    _run(sim, core, 0.3)
    near = _mid(sim, joint, 0.3)
    assert core.topic(Goal([joint], [Point(0.5, (near,))])) is None
    _run(sim, core, 1.5)
    assert sim.positions()[joint] == pytest.approx(near, abs=0.02)


def test_a_topic_trajectory_keeps_the_active_goal(jazzy: tuple[Simulation, JointTrajectoryCore, Sink]) -> None:
    """Jazzy's topic_callback never touches the active goal; update() judges it against the topic's trajectory:
    it succeeds when the joints reach the topic's end, not the goal's."""
    sim, core, sink = jazzy
    joints = core.joints[:2]
    assert core.submit(Goal(joints, [Point(5.0, tuple(_mid(sim, j, 0.8) for j in joints))]), "goal") is None
    _run(sim, core, 0.3)
    target = tuple(_mid(sim, j, 0.2) for j in joints)
    assert core.topic(Goal(joints, [Point(0.5, target)])) is None
    assert sink.results == []
    _run(sim, core, 2.0)
    assert sink.results == [("goal", Result(Status.SUCCEEDED, ErrorCode.SUCCESSFUL, ""))]
    assert [sim.positions()[j] for j in joints] == pytest.approx(target, abs=0.02)


def test_a_partial_topic_trajectory_stops_the_others(jazzy: tuple[Simulation, JointTrajectoryCore, Sink]) -> None:
    sim, core, _ = jazzy
    first, second = core.joints[0], core.joints[1]
    assert core.topic(Goal([first], [Point(3.0, (_mid(sim, first, 0.95),))])) is None
    _run(sim, core, 0.5)
    assert core.topic(Goal([second], [Point(0.3, (sim.desired([second]).positions[0],))])) is None
    held = sim.desired([first]).positions[0]
    _run(sim, core, 1.0)
    assert sim.desired([first]).positions[0] == pytest.approx(held, abs=1e-9)


@pytest.mark.parametrize(
    "case",
    ["nan", "unknown", "not_increasing", "wrong_size", "empty", "moving_end", "no_joints"],
)
def test_malformed_topic_trajectories_change_nothing(
    case: str, jazzy: tuple[Simulation, JointTrajectoryCore, Sink]
) -> None:
    sim, core, sink = jazzy
    joint = core.joints[0]
    target = _mid(sim, joint, 0.7)
    goal = {
        "nan": Goal([joint], [Point(0.5, (math.nan,))]),
        "unknown": Goal(["nobody"], [Point(0.5, (target,))]),
        "not_increasing": Goal([joint], [Point(0.5, (target,)), Point(0.5, (target,))]),
        "wrong_size": Goal([joint, core.joints[1]], [Point(0.5, (target,))]),
        "empty": Goal([joint], []),
        "moving_end": Goal([joint], [Point(0.5, (target,), (0.2,))]),
        "no_joints": Goal([], [Point(0.5, ())]),
    }[case]
    before = sim.positions()[joint]
    assert isinstance(core.topic(goal), Rejection)
    assert sink.warned and "joint_trajectory: trajectory rejected" in sink.warned[-1]
    _run(sim, core, 0.6)
    assert sim.positions()[joint] == pytest.approx(before, abs=2e-3)


def test_query_state_during_and_after(jazzy: tuple[Simulation, JointTrajectoryCore, Sink]) -> None:
    sim, core, _ = jazzy
    joint = core.joints[0]
    assert core.sample_current(sim.time)[0] is None  # holding: no trajectory
    assert core.topic(Goal([joint], [Point(1.0, (_mid(sim, joint, 0.6),))])) is None
    state, why = core.sample_current(sim.time + 0.5)
    assert state is not None and len(state.positions) == len(core.joints), why
    assert core.sample_current(sim.time - 1.0)[0] is None
    _run(sim, core, 1.2)
    assert core.sample_current(sim.time)[0] is None
    core.stopping()
    assert "not active" in core.sample_current(sim.time)[1]
