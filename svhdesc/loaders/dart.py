"""DART (PyPI ``dartpy``): DartLoader turns each <mimic> into a MIMIC actuator that drives the follower.

    skeleton = load_dart("svh_right")
    world = dartpy.simulation.World(); world.addSkeleton(skeleton)
    skeleton.getJoint("right_hand_Pinky").setCommand(0, torque); world.step()

DART 6.20 offers two ways to hold a mimic joint: its default mimic motor (one-way: it drives the
follower; the channel does not feel the follower's load) and a two-way coupler constraint
(``setUseCouplerConstraint``). Driving every channel of svh_right to mid-range for 1 s at 1 ms with
velocity servos, the motor holds every coupling within 3e-5 rad; the coupler constraint leaves them up to
7e-3 rad off and an index channel 0.13 rad short of its target (dartpy 6.20). So the default stays the
motor; ``coupler=True`` switches.
"""

from __future__ import annotations

from typing import Any

from svhdesc.loaders._common import absolute_urdf, couplings, require


def load_dart(name: str = "ur5_svh_right", coupler: bool = False) -> Any:
    """``dartpy.dynamics.Skeleton`` of the variant, fixed to the world by its URDF 'world' link."""
    dart = require("dartpy", "load_dart")
    path = absolute_urdf(name)
    skeleton = dart.utils.DartLoader().parseSkeleton(str(path))
    if skeleton is None:
        raise RuntimeError(f"DART could not parse {path}")
    for coupling in couplings(name):
        joint = skeleton.getJoint(coupling.joint)
        if joint.getActuatorType() != dart.dynamics.ActuatorType.MIMIC:
            raise RuntimeError(f"DART did not parse the <mimic> of {coupling.joint}")
        joint.setUseCouplerConstraint(coupler)
    return skeleton
