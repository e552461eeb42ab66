"""svhdesc/ros2/graph.py without ROS: /tf's kinematics against MuJoCo's own, SCHUNK's current/effort conversion,
the yaml's parameters as dotted names. The node's use of them runs in tests/ros2/test_driver_interfaces.py.

Seeded faults (each failed its test, then reverted): Kinematics multiplying the joint's turn before the origin's
rotation -> the arm's transforms differ from MuJoCo's; current_and_effort without abs() -> a negative force gives a
negative current; flat() keeping empty lists -> the empty list is declared."""

from __future__ import annotations

import math

import mujoco
import numpy as np
import pytest

from svhdesc.model import get, ros2_joint_name
from svhdesc.ros2.graph import Kinematics, controller_parameters, current_and_effort, description, flat
from svhdesc.sim import Point, Simulation


def test_tf_matches_mujocos_bodies() -> None:
    """Every moving URDF joint whose parent and child links are MuJoCo parent and child bodies: the transform
    robot_state_publisher's way (origin, then the joint's turn about its axis) equals MuJoCo's relative pose, with the
    arm and two channels moved away from zero."""
    variant = "ur5_svh_right"
    directory = get(variant).directory
    urdf = description(directory / "ros2/urdf" / f"{variant}.urdf.xacro", directory / "ros2/config/x.yaml")
    kinematics = Kinematics(urdf)
    sim = Simulation(variant, "home")
    sim.follow(list(sim.info.arm_joints[:3]), [Point(0.5, (0.3, -0.5, 0.4))])
    sim.follow(list(sim.info.hand_channels[:2]), [Point(0.5, (0.5, 0.5))])
    sim.run(1.0, realtime=False)
    mujoco.mj_kinematics(sim.model, sim.data)
    state = sim.joint_state()
    where = dict(zip((ros2_joint_name(j) for j in state.names), state.positions))
    translation, rotation = kinematics.moving(np.array([where.get(j, 0.0) for j in kinematics.joints]))
    model, data = sim.model, sim.data
    checked = 0
    for (parent, child), shift, turn in zip(kinematics.frames, translation, rotation):
        try:
            p, c = model.body(parent).id, model.body(child).id
        except KeyError:
            continue
        if model.body_parentid[c] != p:
            continue
        relative = data.xmat[p].reshape(3, 3).T @ (data.xpos[c] - data.xpos[p])
        quaternion = np.zeros(4)
        mujoco.mju_mulQuat(quaternion, data.xquat[p] * np.array([1, -1, -1, -1]), data.xquat[c])
        ours = np.array([turn[3], *turn[:3]])  # (w, x, y, z)
        assert relative == pytest.approx(shift, abs=1e-9), (parent, child)
        assert min(np.abs(ours - quaternion).max(), np.abs(ours + quaternion).max()) < 1e-9, (parent, child)
        checked += 1
    assert checked >= 20


def test_current_and_effort_through_the_librarys_constants() -> None:
    """Thumb_Flexion (0.015 N/mA, -1.543 N): 1.0 N asks (1.0 + 1.543) / 0.015 = 169.5 -> 170 mA, read back as
    0.015 * 170 - 1.543 N; the sign of the force does not matter (convertmAtoN takes |current|); channels without
    constants give NaN mA and 0 N."""
    current, effort = current_and_effort(0, 1.0)
    assert current == 170.0 and effort == pytest.approx(0.015 * 170 - 1.543)
    assert current_and_effort(0, -1.0) == (current, effort)
    assert current_and_effort(0, 0.0)[0] == 103.0  # round(1.543 / 0.015) = round(102.87)
    opposition = current_and_effort(1, 0.5)
    assert math.isnan(opposition[0]) and opposition[1] == 0.0


def test_parameters_as_dotted_names() -> None:
    declared = controller_parameters(
        "joint_trajectory_controller/JointTrajectoryController",
        {"joints": ["a"], "gpio": [], "constraints": {"goal_time": 0.5, "a": {"goal": 0.1}}},
        "joint_trajectory_controller/JointTrajectoryController",
    )
    assert declared["joints"] == ["a"] and "gpio" not in declared
    assert declared["constraints.goal_time"] == 0.5 and declared["constraints.a.goal"] == 0.1
    assert declared["allow_partial_joints_goal"] is False  # JTC's default, declared where the yaml has none
    assert flat({"x": {"y": {"z": 1}}}) == {"x.y.z": 1}
