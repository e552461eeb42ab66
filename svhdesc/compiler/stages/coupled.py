"""The coupling processor: the spec's channels and couplings onto the robot's joints."""

from __future__ import annotations

import warnings
from dataclasses import dataclass

from svhdesc.compiler.export.urdf import mimic_order_problems
from svhdesc.compiler.stages.assets import Assets
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
