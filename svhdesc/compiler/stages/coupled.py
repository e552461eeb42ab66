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
    for problem in mimic_order_problems(robot):
        # A warning, not an error: the URDF is valid, only pinocchio's mimic=True cannot load it.
        warnings.warn(f"{problem}: pinocchio cannot build its mimic model (rename a sibling joint)", stacklevel=2)
    return robot
