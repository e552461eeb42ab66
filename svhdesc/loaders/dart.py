"""DART (PyPI ``dartpy``): DartLoader turns each <mimic> into a MIMIC actuator; the loader makes
each one a coupler constraint.

    skeleton = load_dart("svh_right")
    world = dartpy.simulation.World(); world.addSkeleton(skeleton)
    skeleton.getJoint("right_hand_Pinky").setCommand(0, torque); world.step()

DART's default mimic is a one-way motor: it drives the follower but the channel never feels the
follower's load. The SVH coupling is a rigid linkage, so the loader switches every mimic joint to
DART's two-way coupler constraint (``setUseCouplerConstraint``).
"""

from __future__ import annotations

from typing import Any

from ._common import absolute_urdf, couplings, require


def load_dart(name: str = "ur5_svh_right", coupler: bool = True) -> Any:
    """``dartpy.dynamics.Skeleton`` of the variant, fixed to the world by its URDF 'world' link."""
    dart = require("dartpy", "load_dart")
    skeleton = dart.utils.DartLoader().parseSkeleton(str(absolute_urdf(name)))
    if skeleton is None:
        raise RuntimeError(f"DART could not parse {absolute_urdf(name)}")
    for coupling in couplings(name):
        joint = skeleton.getJoint(coupling.joint)
        if joint.getActuatorType() != dart.dynamics.ActuatorType.MIMIC:
            raise RuntimeError(f"DART did not parse the <mimic> of {coupling.joint}")
        joint.setUseCouplerConstraint(coupler)
    return skeleton
