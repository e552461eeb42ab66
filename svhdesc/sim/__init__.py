"""Simulation runtime without ROS: a variant's scene, targets, JointTrajectoryController-style
trajectories, joint states, fingertip force and body poses (through the public API only)."""

from svhdesc.sim.robot import RobotInfo
from svhdesc.sim.runtime import JointState, Simulation
from svhdesc.sim.trajectory import Point, State, Trajectory

__all__ = [
    "JointState",
    "Point",
    "RobotInfo",
    "Simulation",
    "State",
    "Trajectory",
]
