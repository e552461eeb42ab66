"""Load a built variant into the engines people use, in the spirit of robot_descriptions' loaders.

Each loader imports its engine only when called (a missing engine raises ``svhdesc.extras.MissingExtra``
naming the pip extra) and honours the hand's 11 couplings (the URDF's ``<mimic>``, from ``config/coupling.yaml``):

    from svhdesc.loaders import load_dart, load_drake, load_mujoco, load_newton, load_pinocchio, load_pybullet
    model = load_mujoco("svh_right")                   # mujoco.MjModel (joint equalities)
    robot = load_pinocchio("svh_right")                # pinocchio.RobotWrapper, mimic model: nq = 9
    pb = load_pybullet("svh_right")                    # PybulletRobot(client, body, joints, constraints)
    drake = load_drake("svh_right", time_step=1e-3)    # DrakeRobot(builder, plant, scene_graph, instance)
    skeleton = load_dart("svh_right")                  # dartpy Skeleton, coupler constraints
    model = load_newton("svh_right")                   # newton.Model from the USD, 11 joint mimics

``attach(arm, "svh_right", parent=BODY, pos=..., quat=...)`` fixes a built hand to any MJCF arm (mujoco.MjSpec).

The same functions are exported lazily from ``svhdesc`` (``svhdesc.load_pybullet`` ...).
"""

from __future__ import annotations

from svhdesc.loaders._common import couplings
from svhdesc.loaders.dart import load_dart
from svhdesc.loaders.drake import DrakeRobot, load_drake
from svhdesc.loaders.hand_on_arm import attach
from svhdesc.loaders.mujoco import load_mujoco
from svhdesc.loaders.newton import load_newton
from svhdesc.loaders.pinocchio import load_pinocchio
from svhdesc.loaders.pybullet import PybulletRobot, load_pybullet
from svhdesc.model import Coupling

__all__ = [
    "Coupling",
    "DrakeRobot",
    "PybulletRobot",
    "attach",
    "couplings",
    "load_dart",
    "load_drake",
    "load_mujoco",
    "load_newton",
    "load_pinocchio",
    "load_pybullet",
]
