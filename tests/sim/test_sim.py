"""The ROS-free simulation runtime: JointTrajectoryController interpolation, home -> test, readings."""

from __future__ import annotations

import math
import os
import re
import shutil
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from svhdesc.core.settings.coupling import load_spec
from svhdesc.errors import SvhdescError
from svhdesc.sim import Point, Simulation, State, Trajectory
from tests.support import REPO, run_cli

mujoco = pytest.importorskip("mujoco")


def _start(n: int, p: float = 0.0, v: float = 0.0, a: float = 0.0) -> State:
    return State(np.full(n, p), np.full(n, v), np.full(n, a))


def _numeric_derivative(trajectory: Trajectory, t: float, h: float = 1e-6) -> np.ndarray:
    return (trajectory.sample(t + h).positions - trajectory.sample(t - h).positions) / (2 * h)


def test_positions_only_interpolate_linearly() -> None:
    trajectory = Trajectory(["a"], _start(1, 1.0), 10.0, [Point(2.0, (3.0,))])
    assert trajectory.sample(11.0).positions[0] == pytest.approx(2.0)
    assert trajectory.sample(11.5).velocities[0] == pytest.approx(1.0)
    assert trajectory.sample(9.0).positions[0] == 1.0  # before the start: the start state
    end = trajectory.sample(20.0)
    assert end.positions[0] == 3.0 and end.velocities[0] == 0.0


def test_velocities_give_a_cubic_and_accelerations_a_quintic() -> None:
    cubic = Trajectory(["a", "b"], _start(2, 0.0, 0.5), 0.0, [Point(1.0, (1.0, -1.0), (0.2, 0.0))])
    quintic = Trajectory(["a", "b"], _start(2, 0.0, 0.5, 1.0), 0.0, [Point(1.0, (1.0, -1.0), (0.2, 0.0), (-2.0, 3.0))])
    for trajectory in (cubic, quintic):
        near_end = trajectory.sample(1.0 - 1e-9)
        assert near_end.positions == pytest.approx([1.0, -1.0], abs=1e-6)
        assert near_end.velocities == pytest.approx([0.2, 0.0], abs=1e-6)
        assert _numeric_derivative(trajectory, 0.5) == pytest.approx(trajectory.sample(0.5).velocities, rel=1e-5)
        assert trajectory.sample(0.0).velocities == pytest.approx([0.5, 0.5])
    assert quintic.sample(1.0 - 1e-9).accelerations == pytest.approx([-2.0, 3.0], abs=1e-5)
    assert quintic.sample(0.0).accelerations == pytest.approx([1.0, 1.0])
    # A cubic cannot match end accelerations: its curvature differs from the quintic's.
    assert not np.allclose(cubic.sample(0.5).positions, quintic.sample(0.5).positions)


def test_points_in_the_past_are_dropped() -> None:
    trajectory = Trajectory(["a"], _start(1, 0.0), 0.0, [Point(1.0, (5.0,)), Point(2.0, (6.0,))], now=1.5)
    assert trajectory.sample(1.5).positions[0] == 0.0  # starts from the current state at now
    assert trajectory.sample(1.75).positions[0] == pytest.approx(3.0)
    assert trajectory.end_time == 2.0


@pytest.fixture(scope="module")
def home_to_test() -> Simulation:
    sim = Simulation("ur5_svh_right", "home")
    key = sim.model.key("test")
    test = dict(zip(sim.info.actuators, key.ctrl))
    for group in (sim.info.arm_joints, sim.info.hand_channels):
        sim.follow(group, [Point(4.0, tuple(test[n] for n in group))])
    sim.advance(4.5)
    return sim


def test_home_to_test_reaches_the_keyframe(home_to_test: Simulation) -> None:
    sim = home_to_test
    test = dict(zip(sim.info.actuators, sim.model.key("test").ctrl))
    positions = sim.positions()
    assert len(sim.info.hand_channels) == 9 and len(sim.info.arm_joints) == 6
    assert len(positions) == 26  # every joint, the 11 coupled ones included
    for name, target in test.items():
        assert abs(positions[name] - target) < 2e-3, name
    assert len(sim.info.couplings) == 11
    for coupling in sim.info.couplings:
        assert positions[coupling.joint] == pytest.approx(coupling.value(positions[coupling.leader]), abs=1e-4)
    assert np.all(np.isfinite(sim.joint_state().velocities))


def test_body_pose_follows_the_arm(home_to_test: Simulation) -> None:
    fresh = Simulation("ur5_svh_right", "home")
    moved, _ = home_to_test.body_pose("tool0")
    still, quaternion = fresh.body_pose("tool0")
    assert np.linalg.norm(moved - still) > 0.1
    assert np.linalg.norm(quaternion) == pytest.approx(1.0)
    with pytest.raises(SvhdescError, match="no body"):
        fresh.body_pose("nothing")


def test_bad_commands_are_refused_and_state_stays_finite() -> None:
    sim = Simulation("svh_right", "home")
    with pytest.raises(SvhdescError, match="not finite"):
        sim.set_target("Pinky", math.nan)
    with pytest.raises(SvhdescError, match="not an actuated joint"):
        sim.set_target("right_hand_j12", 0.1)  # coupled, not a channel
    with pytest.raises(SvhdescError, match="outside its range"):
        sim.follow(["Pinky"], [Point(1.0, (3.0,))])
    with pytest.raises(SvhdescError, match="does not increase"):
        sim.follow(["Pinky"], [Point(1.0, (0.1,)), Point(1.0, (0.2,))])
    sim.advance(0.1)
    assert np.all(np.isfinite(sim.data.qpos))


def test_targets_by_channel_name_and_gains_of_eq_4_2() -> None:
    sim = Simulation("svh_right", "home")
    sim.set_target("Pinky", 0.5)  # a bare channel name means the prefixed joint
    sim.advance(2.0)  # at its driver effort (0.19 N m) against the drives' damping the pinky makes ~0.4 rad/s
    assert sim.positions()["right_hand_Pinky"] == pytest.approx(0.5, abs=2e-3)
    p_gain, d_gain = sim.gains("Pinky")
    assert p_gain == 10.0 and d_gain > 0
    sim.set_gains("Ring_Finger", 0.0, d_gain)  # no stiffness: the servo cannot move the finger
    sim.set_target("Ring_Finger", 0.5)
    sim.advance(0.5)
    assert sim.positions()["right_hand_Ring_Finger"] < 0.05


def test_fingertip_contact_gives_force_and_wrench() -> None:
    probe = Simulation("svh_right", "home")
    tip = probe.touch_body()
    assert tip == "right_hand_t"
    centre, _ = probe.body_pose(tip)

    def add_block(spec) -> None:  # a fixed block just overlapping the index fingertip from above
        spec.worldbody.add_geom(
            name="block", type=mujoco.mjtGeom.mjGEOM_BOX, size=[0.02, 0.02, 0.02], pos=centre + [0, 0, 0.03]
        )

    sim = Simulation("svh_right", "home", edit=add_block)
    sim.advance(0.2)
    force, torque = sim.contact_wrench(tip)
    assert sim.fingertip_force() > 0.0
    assert np.linalg.norm(force) > 0.0 and np.all(np.isfinite(torque))
    rotation = sim.data.xmat[sim.model.body(tip).id].reshape(3, 3)
    assert (rotation @ force)[2] < 0  # the block pushes the fingertip down
    assert probe.contact_wrench(tip)[0] == pytest.approx(np.zeros(3))


def test_cli_runs_and_refuses_bad_input() -> None:
    result = run_cli("sim", "svh_left", "--as-fast", "--duration", "0.1", "--track", "left_hand_t")
    assert result.returncode == 0, result.stderr
    assert "left_hand_Pinky" in result.stdout and "left_hand_t: xyz" in result.stdout
    for args, culprit in (
        (("--keyframe", "nope"), "nope"),
        (("--track", "nobody"), "nobody"),
        (("--duration", "-1"), "--duration"),
    ):
        result = run_cli("sim", "svh_left", "--as-fast", *args)
        assert result.returncode == 2 and result.stderr.startswith("error:") and culprit in result.stderr
        assert "Traceback" not in result.stderr


def test_realtime_run_keeps_to_the_wall_clock() -> None:
    sim = Simulation("svh_right", "home")
    start = time.perf_counter()
    factor = sim.run(0.3, realtime=True)
    assert time.perf_counter() - start >= 0.29
    assert sim.time == pytest.approx(0.3, abs=sim.timestep)
    assert factor <= 1.05


@pytest.mark.skipif(shutil.which("xvfb-run") is None, reason="xvfb-run (package xvfb) is not installed")
def test_passive_viewer_under_xvfb() -> None:
    result = subprocess.run(
        ["xvfb-run", "-a", str(Path(sys.executable).with_name("svhdesc")), "sim", "svh_right", "--viewer"]
        + ["--duration", "0.3"],
        capture_output=True,
        text=True,
        timeout=120,
        env={**os.environ, "LIBGL_ALWAYS_SOFTWARE": "1"},
    )
    assert result.returncode == 0, result.stderr
    assert "svh_right: simulated 0.300 s" in result.stdout


@pytest.mark.parametrize("variant", ["svh_right", "svh_left", "ur5_svh_right"])
def test_connector_file_matches_the_model(variant: str) -> None:
    """One entry per actuated joint, each topic its own (the thesis' file misspelt one), the servo's gains."""
    import svhdesc
    from svhdesc.ros1.connector import load_connector

    joints = load_connector(svhdesc.get(variant).directory / "config" / "connector.yaml")
    sim = Simulation(variant)
    assert [j.name for j in joints] == list(sim.info.actuators)
    topics = [t for j in joints for t in (j.control_topic, j.pose_topic, j.initpose_topic)]
    assert len(set(topics)) == len(topics)
    for joint in joints:
        assert all(joint.name in t for t in (joint.control_topic, joint.pose_topic, joint.initpose_topic))
        assert (joint.p_gain, joint.d_gain) == pytest.approx(sim.gains(joint.name))


def test_bad_connector_files_name_the_culprit(tmp_path: Path) -> None:
    from svhdesc.ros1.connector import load_connector

    path = tmp_path / "connector.yaml"
    for text, culprit in (
        ("joints: 3\n", "'joints:' list"),
        ("joints:\n- {name: a}\n", "joints[0]: missing"),
        (
            "joints:\n- {name: a, control_topic: c, pose_topic: p, initpose_topic: i, p_gain: .nan, d_gain: 1}\n",
            "p_gain",
        ),
        ("joints: [\n", "not YAML"),
    ):
        path.write_text(text)
        with pytest.raises(SvhdescError, match=re.escape(culprit)):
            load_connector(path)


def test_run_without_an_end_stops_when_the_callback_says_so() -> None:
    sim = Simulation("svh_right")
    calls = []

    def three_times(_: Simulation) -> bool:
        calls.append(sim.time)
        return len(calls) < 3

    assert sim.run(math.inf, realtime=False, every=0.02, callback=three_times) > 0
    assert len(calls) == 3 and sim.time == pytest.approx(0.06)


def _stroke_speeds(setpoint_ramp: bool) -> dict[str, tuple[float, float, float]]:
    """Per hand channel of svh_right, commanded in one step from its lower to its upper end: (fastest speed over
    0.1 s, where it is after range / driver velocity + 1.5 s, its upper end)."""
    sim = Simulation("svh_right", keyframe="home", setpoint_ramp=setpoint_ramp)
    spec = {c.name: c for c in load_spec(REPO / "config" / "coupling.yaml").channels}
    result = {}
    for joint in sim.info.hand_channels:
        channel = joint.removeprefix("right_hand_")
        low, high = sim.limits(joint)
        sim.reset("home")
        sim.set_joint_position(joint, low)
        sim.set_target(joint, high)
        positions = [sim.positions()[joint]]
        for _ in range(math.ceil(((high - low) / spec[channel].velocity + 1.5) / 0.1)):
            sim.advance(0.1)
            positions.append(sim.positions()[joint])
        result[channel] = (float(np.max(np.diff(positions))) / 0.1, positions[-1], high)
    return result


def test_hand_channels_move_at_most_at_the_drivers_velocity() -> None:
    """The SVH firmware ramps each channel's setpoint at its velocity limit (the driver's maximum step per second,
    config/coupling.yaml): a step command to the far end moves no faster and still arrives. Without the ramp the
    servos alone move the thumb five times as fast as the real one."""
    spec = {c.name: c.velocity for c in load_spec(REPO / "config" / "coupling.yaml").channels}
    ramped = _stroke_speeds(True)
    assert set(ramped) == set(spec)
    for channel, (speed, reached, high) in ramped.items():
        assert speed <= spec[channel] * 1.02, (channel, speed, spec[channel])
        assert reached == pytest.approx(high, abs=0.01 * high), channel
    free = _stroke_speeds(False)
    assert free["Thumb_Flexion"][0] > 3 * spec["Thumb_Flexion"]  # what the ramp prevents
