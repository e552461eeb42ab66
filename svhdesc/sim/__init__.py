"""Simulation runtime without ROS: a variant's scene, targets, JointTrajectoryController-style
trajectories, joint states, fingertip force and body poses (through the public API only)."""

from svhdesc.sim.robot import DRIVER_CHANNELS, Coupling, RobotInfo
from svhdesc.sim.runtime import JointState, Simulation
from svhdesc.sim.trajectory import Point, State, Trajectory

__all__ = [
    "DRIVER_CHANNELS",
    "Coupling",
    "JointState",
    "Point",
    "RobotInfo",
    "Simulation",
    "State",
    "Trajectory",
]
