"""Simulation runtime without ROS: a variant's scene, targets, JointTrajectoryController-style
trajectories, joint states, fingertip force and body poses (through the public API only). ``Point``, ``State`` and
``Trajectory`` are the controllers' (svhdesc.control.spline), which the simulation follows between updates."""

from svhdesc.control.spline import Point, State, Trajectory
from svhdesc.sim.robot import RobotInfo
from svhdesc.sim.runtime import JointState, Simulation

__all__ = [
    "JointState",
    "Point",
    "RobotInfo",
    "Simulation",
    "State",
    "Trajectory",
]
