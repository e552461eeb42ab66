"""velocity_tracking on a robot file as it stands (the full tier of `svhdesc validate PATH`): every velocity servo
(an actuator on a joint whose force is kv (ctrl - qdot): MJCF's <velocity>, a wheel's motor) turns its joint at the
velocity commanded, as the built variants' check asks (svhdesc.validate.velocity): from the rest pose, alone, SHARE
of its ctrlrange's end one way, then the other, the other actuators holding their rest targets, gravity and
contacts on; over the last half of RUN s the mean velocity must be within TOLERANCE of the command. A URDF states no
velocity servo (the full tier gives every joint a position servo): skipped.
"""

from __future__ import annotations

import numpy as np

from svhdesc.model import velocity_servos
from svhdesc.validate.compile_file import Compiled
from svhdesc.validate.findings import CheckResult, Finding
from svhdesc.validate.velocity import RUN, SHARE, TOLERANCE, tracked

CHECK = "velocity_tracking"


def velocity_tracking(compiled: Compiled) -> CheckResult:
    model = compiled.model
    servos = velocity_servos(model)
    actuators = [a for a in range(model.nu) if model.joint(int(model.actuator_trnid[a, 0])).name in servos]
    if not actuators:
        return CheckResult(CHECK, "skipped", reason="no velocity servo (an actuator with force kv (ctrl - qdot))")
    findings, worst = [], 0.0
    for actuator in actuators:
        joint = model.joint(int(model.actuator_trnid[actuator, 0])).name
        top = float(np.max(np.abs(model.actuator_ctrlrange[actuator]))) if model.actuator_ctrllimited[actuator] else 1.0
        for command in (SHARE * top, -SHARE * top):
            speed = tracked(model, actuator, command, compiled.key)
            error = abs(speed - command) / abs(command) if np.isfinite(speed) else np.inf
            worst = max(worst, error)
            if error > TOLERANCE:
                file, line = compiled.where("rating", joint)
                message = (
                    f"joint '{joint}' turns at {speed:.4g} for a command of {command:.4g} from its velocity servo "
                    f"(mean over the last {RUN / 2:g} s of {RUN:g}; off by {error:.1%}, bound {TOLERANCE:.0%})"
                )
                findings.append(Finding(CHECK, file, line, message))
    figure = f"{len(actuators)} velocity servo(s) at +-{SHARE:g} x their ctrlrange, worst off by {worst:.1%}"
    return CheckResult(CHECK, "fail" if findings else "pass", findings, figure=figure)
