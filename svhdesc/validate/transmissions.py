"""Every actuated joint (each MJCF actuator's joint) has a URDF <transmission> for ros_control."""

from __future__ import annotations

from svhdesc.model import actuated_joints
from svhdesc.validate.options import Options
from svhdesc.validate.pair import ModelPair
from svhdesc.validate.report import Check, not_run, verdict


def check_transmissions(pair: ModelPair, options: Options) -> list[Check]:
    bound = "one per actuated joint"
    if pair.model is None or pair.urdf is None:
        return [not_run("transmissions", "needs both files", bound)]
    actuated = list(actuated_joints(pair.model))
    covered = {joint for joints in pair.urdf.transmissions.values() for joint in joints}
    missing = [j for j in actuated if j not in covered]
    unknown = sorted(j for j in covered if j not in pair.urdf.joints)
    problems = []
    if missing:
        problems.append(f"no <transmission> for {', '.join(missing)}")
    if unknown:
        problems.append(f"<transmission> names unknown joint(s) {', '.join(unknown)}")
    return [
        Check(
            "transmissions",
            verdict(not problems),
            f"{len(actuated) - len(missing)}/{len(actuated)}",
            bound,
            "; ".join(problems) or f"{len(pair.urdf.transmissions)} transmissions",
            {"actuated": actuated, "missing": missing, "unknown_joints": unknown},
        )
    ]
