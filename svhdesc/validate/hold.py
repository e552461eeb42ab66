"""Check ``gravity_hold``: at each keyframe, gravity and contacts on, the servos commanded to the keyframe's
targets hold every hinge and slide joint (but a velocity servo's) within BOUND of the keyframe for HOLD seconds,
after SETTLE seconds in which the servos, couplings and contacts take up the load. Any robot: a weak arm servo lets
its joint sag.

Keyframes that close a configured grasp are left out (they command the fingers into an object that is not there).
A joint the keyframe puts at a limit (within the limit's margin) may sit up to twice that margin off it, where
MuJoCo's soft limit, active inside the margin, balances its servo: that much more is allowed to it (the SVH's
channels at 0 sit 2 mrad off their stops, their limit margin being 1 mrad).
A state that has come to rest (every velocity and acceleration ~ 0) stays there, so the window ends early then.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from svhdesc.model import scalar_joints, velocity_servos
from svhdesc.validate.options import Options
from svhdesc.validate.pair import ModelPair
from svhdesc.validate.report import Check, fmt, not_run, skipped, verdict

BOUND = 2e-3  # rad (m for a slide joint)
SETTLE = 0.5  # s before the window
HOLD = 2.0  # s: the window
AT_REST_VEL = 1e-9  # rad/s
AT_REST_ACC = 1e-6  # rad/s^2


@dataclass(frozen=True)
class Hold:
    """One keyframe held: the worst joint, how far it left the keyframe in the window, the largest move in the
    settling phase, and where the state went non-finite (None if it did not)."""

    key: str
    joint: str
    drift: float
    settle_peak: float
    diverged_at: float | None
    bound: float  # BOUND, plus the at-limit allowance of this joint


def hold_keyframe(model: Any, key: int) -> Hold:
    """Hold keyframe ``key`` (its ctrl as the servo targets) for SETTLE + HOLD seconds."""
    import mujoco

    data = mujoco.MjData(model)
    mujoco.mj_resetDataKeyframe(model, data, key)
    velocity = velocity_servos(model)  # they hold a velocity (0), not a position: velocity_tracking's
    joints = [j for j in scalar_joints(model) if model.joint(j).name not in velocity]
    adr = np.array([model.jnt_qposadr[j] for j in joints], dtype=int)
    reference = data.qpos[adr].copy()
    allowed = BOUND + at_limit_allowance(model, joints, reference)
    worst, peak = np.zeros(len(joints)), 0.0
    settle_steps = int(round(SETTLE / model.opt.timestep))
    for step in range(settle_steps + int(round(HOLD / model.opt.timestep))):
        mujoco.mj_step(model, data)
        if not (np.isfinite(data.qpos).all() and np.isfinite(data.qvel).all()):
            return Hold(model.key(key).name, "-", float("inf"), float("inf"), step * model.opt.timestep, BOUND)
        moved = np.abs(data.qpos[adr] - reference)
        if step < settle_steps:
            peak = max(peak, float(moved.max(initial=0.0)))
            continue
        np.maximum(worst, moved, out=worst)
        if np.abs(data.qvel).max(initial=0.0) < AT_REST_VEL and np.abs(data.qacc).max(initial=0.0) < AT_REST_ACC:
            break  # at rest: an equilibrium of a system without time-varying input stays put
    if not joints:
        return Hold(model.key(key).name, "-", 0.0, peak, None, BOUND)
    i = int(np.argmax(worst - allowed))  # the joint nearest its bound
    return Hold(model.key(key).name, model.joint(joints[i]).name, float(worst[i]), peak, None, float(allowed[i]))


def at_limit_allowance(model: Any, joints: list[int], q: np.ndarray) -> np.ndarray:
    """Twice the limit margin for each joint that ``q`` puts within its margin of a limit, else 0."""
    result = np.zeros(len(joints))
    for i, j in enumerate(joints):
        if model.jnt_limited[j]:
            low, high = model.jnt_range[j]
            margin = float(model.jnt_margin[j])
            if margin > 0 and min(q[i] - low, high - q[i]) <= margin:
                result[i] = 2.0 * margin
    return result


def check_gravity_hold(pair: ModelPair, options: Options) -> list[Check]:
    bound = f"every joint within {BOUND * 1e3:g} mrad (mm, +2 x margin at a limit) of the keyframe for {HOLD:g} s"
    if pair.model is None:
        return [not_run("gravity_hold", "the MJCF does not compile", bound)]
    model = pair.model
    grasps = set(pair.configuration.settings.grasps) if pair.configuration is not None else set()
    keys = [k for k in range(model.nkey) if model.key(k).name not in grasps]
    if not keys:
        return [skipped("gravity_hold", "no keyframes" + (" besides grasps" if model.nkey else ""), bound)]
    if model.nu == 0:
        return [skipped("gravity_hold", "no actuators: nothing holds a pose", bound)]
    holds = [hold_keyframe(model, k) for k in keys]
    bad = [h for h in holds if h.diverged_at is not None or h.drift > h.bound]
    worst = max(holds, key=lambda h: h.drift - h.bound)
    problems = [
        f"{h.key}: diverged at t = {h.diverged_at:.3f} s"
        if h.diverged_at is not None
        else f"{h.key}: {h.joint} leaves it by {h.drift * 1e3:.3g} mrad (bound {h.bound * 1e3:.3g})"
        for h in bad
    ]
    left_out = f" (grasps left out: {', '.join(sorted(grasps))})" if grasps else ""
    return [
        Check(
            "gravity_hold",
            verdict(not bad),
            f"{fmt(worst.drift * 1e3)} of {fmt(worst.bound * 1e3)} mrad ({worst.key}: {worst.joint})",
            bound,
            "; ".join(problems) or f"keyframes {', '.join(h.key for h in holds)}{left_out}",
            {
                "bound": BOUND,
                "keyframes": {
                    h.key: {
                        "joint": h.joint,
                        "drift": h.drift,
                        "bound": h.bound,
                        "settle_peak": h.settle_peak,
                        "diverged_at_s": h.diverged_at,
                    }
                    for h in holds
                },
            },
        )
    ]
