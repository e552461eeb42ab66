"""Check ``velocity_tracking``: a joint on a velocity servo (``joints.NAME.servo: velocity``: a wheel's motor) turns
at the velocity it is commanded. From ``home``, each such joint alone is commanded SHARE of its rated velocity (its
servo's ctrlrange) one way, then the other, the other servos holding home, gravity and contacts on; over the last
half of RUN s its mean velocity must be within TOLERANCE of the command. A velocity servo holds no position:
``range_of_motion`` and ``gravity_hold`` leave its joint out.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from svhdesc.model import velocity_servos
from svhdesc.validate.options import Options
from svhdesc.validate.pair import ModelPair
from svhdesc.validate.report import Check, fmt, not_run, skipped, verdict

SHARE = 0.5  # of the rated velocity
RUN = 1.0  # s per direction
TOLERANCE = 0.05  # of the commanded velocity


def tracked(model: Any, actuator: int, command: float, key: int | None = None) -> float:
    """The joint's mean velocity over the last half of RUN s at ``command`` (from keyframe ``key``, else home, the
    others held)."""
    import mujoco

    data = mujoco.MjData(model)
    home = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_KEY, "home") if key is None else key
    if home >= 0 and model.nkey:
        mujoco.mj_resetDataKeyframe(model, data, home)
    data.ctrl[actuator] = command
    dof = int(model.jnt_dofadr[model.actuator_trnid[actuator, 0]])
    steps = round(RUN / model.opt.timestep)
    speeds = []
    for step in range(steps):
        mujoco.mj_step(model, data)
        if step >= steps // 2:
            speeds.append(float(data.qvel[dof]))
    return float(np.mean(speeds)) if speeds and np.isfinite(speeds).all() else float("nan")


def check_velocity_tracking(pair: ModelPair, options: Options) -> list[Check]:
    bound = f"mean velocity within {TOLERANCE:.0%} of {SHARE:g} x the rated one, both ways, for {RUN:g} s"
    if pair.model is None:
        return [not_run("velocity_tracking", "the MJCF does not compile", bound)]
    model = pair.model
    servos = velocity_servos(model)
    actuators = [a for a in range(model.nu) if model.joint(int(model.actuator_trnid[a, 0])).name in servos]
    if not actuators:
        return [skipped("velocity_tracking", "no velocity servos", bound)]
    errors: dict[str, float] = {}
    for a in actuators:
        rated = float(model.actuator_ctrlrange[a, 1])
        worst = 0.0
        for command in (SHARE * rated, -SHARE * rated):
            error = abs(tracked(model, a, command) - command) / abs(command)
            worst = worst if error <= worst else error  # NaN (diverged) stays the worst
        errors[model.joint(int(model.actuator_trnid[a, 0])).name] = worst
    joint = max(errors, key=lambda j: errors[j] if np.isfinite(errors[j]) else np.inf)
    bad = {j: e for j, e in errors.items() if not e <= TOLERANCE}
    detail = ", ".join(f"{j} off by {e:.1%}" for j, e in bad.items()) or f"{len(errors)} velocity servo(s)"
    return [
        Check(
            "velocity_tracking",
            verdict(not bad),
            f"{fmt(errors[joint] * 100)} % ({joint})",
            bound,
            detail,
            {"relative_error": errors, "share": SHARE, "run_s": RUN},
        )
    ]
