"""The coupling processor: the spec's channels and couplings onto the robot's joints."""

from __future__ import annotations

import warnings
from dataclasses import dataclass

from svhdesc.compiler.assets import Assets
from svhdesc.core.settings.coupling import CouplingSpec, apply_spec
from svhdesc.ir import Robot


@dataclass(frozen=True)
class Coupled:
    """What coupling reads: the loaded spec (an input of the plan), the hand's prefix, ``coupled_limits``."""

    spec: CouplingSpec | None  # None: a robot without couplings
    prefix: str | None
    widen_limits: bool
    prefix_at: str = ""  # file:line of hand.prefix, for a prefix that names no joint


def couple(robot: Robot, assets: Assets, section: Coupled) -> Robot:
    if section.spec is None:
        return robot
    robot = apply_spec(
        robot, section.spec, section.prefix, widen_limits=section.widen_limits, prefix_at=section.prefix_at
    )
    problems = mimic_order_problems(robot)
    if problems:
        # One warning, not an error: the URDF is valid, only pinocchio's own parser (mimic=True) cannot read its
        # mimic joints; svhdesc.load_pinocchio sorts them for it.
        warnings.warn(
            f"{problems[0]}{f' (and {len(problems) - 1} more)' if len(problems) > 1 else ''}: pinocchio's "
            "buildModelFromUrdf(mimic=True) cannot read this URDF's mimic joints; svhdesc.load_pinocchio can",
            stacklevel=2,
        )
    return robot


def urdfdom_joint_order(robot: Robot) -> list[str]:
    """Joints in the order urdfdom-based parsers (pinocchio) visit them: depth first, siblings sorted by
    joint name (urdfdom keeps joints in a std::map, so the file's order does not count)."""
    order: list[str] = []

    def visit(link: str) -> None:
        for joint in sorted(robot.child_joints(link), key=lambda j: j.name.encode()):
            order.append(joint.name)
            visit(joint.child)

    visit(robot.root)
    return order


def mimic_order_problems(robot: Robot) -> list[str]:
    """Coupled joints reached before the joint they mimic, which pinocchio's ``mimic=True`` rejects."""
    position = {name: i for i, name in enumerate(urdfdom_joint_order(robot))}
    return [
        f"{j.name} comes before {j.mimic.joint} in urdfdom's name-sorted traversal"
        for j in robot.joints
        if j.mimic is not None and position[j.name] < position[j.mimic.joint]
    ]
