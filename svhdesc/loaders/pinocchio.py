"""pinocchio (PyPI ``pin``): a RobotWrapper whose coupled joints are pinocchio mimic joints.

    robot = load_pinocchio("svh_right")   # robot.model.nq == 9 (ur5_svh_right: 15); 20 / 26 with mimic=False
    q = pinocchio.neutral(robot.model)     # channels (and arm joints) only
    robot.framesForwardKinematics(q)      # followers move as multiplier * channel + offset

pinocchio's ``mimic=True`` needs each channel parsed before its followers; urdfdom visits sibling
joints sorted by name, and the build keeps every generated URDF in that order (it warns otherwise).
"""

from __future__ import annotations

from typing import Any

from svhdesc.loaders._common import absolute_urdf, require


def load_pinocchio(name: str = "ur5_svh_right", mimic: bool = True) -> Any:
    """``pinocchio.RobotWrapper`` with model, collision and visual geometry (meshes by absolute path)."""
    pinocchio = require("pinocchio", "load_pinocchio")
    return pinocchio.RobotWrapper.BuildFromURDF(str(absolute_urdf(name)), mimic=mimic)
