"""Limits hold under load: random 50 N forces on every fingertip while the targets keep changing.

A servo weaker than the load lets the finger hit its limit; the limit constraint must stop it within
0.01 rad (MuJoCo limits are soft: too soft a solreflimit, or too fast a joint, and it goes through). The
fingertips are the configuration's hand.fingertips (any robot's hand or gripper), an SVH's distal links without one.
"""

from __future__ import annotations

import numpy as np

from svhdesc.validate.handsim import hand_parts
from svhdesc.validate.options import Options
from svhdesc.validate.pair import ModelPair
from svhdesc.validate.report import Check, fmt, not_run, skipped, verdict
from svhdesc.validate.simulate import random_target_start

DURATION = 10.0  # s
TARGET_PERIOD = 0.05  # s between new random targets
LOAD = 50.0  # N per fingertip
LOAD_PERIOD = 0.1  # s between new random directions
BOUND = 0.01  # rad beyond a limit


def check_load_limits(pair: ModelPair, options: Options) -> list[Check]:
    import mujoco

    bound = f"<= {BOUND:g} rad beyond a limit"
    if pair.model is None:
        return [not_run("load_limits", "the MJCF does not compile", bound)]
    model = pair.model
    tips = hand_parts(pair).tips
    limited = [j for j in range(model.njnt) if model.jnt_limited[j]]
    if not tips:
        return [skipped("load_limits", "no fingertips", bound)]
    if not limited:
        return [skipped("load_limits", "no limited joints", bound)]
    data, rng, low, high = random_target_start(model, options.seed)
    adr = np.array([model.jnt_qposadr[j] for j in limited], dtype=int)
    lower, upper = model.jnt_range[limited].T
    dt = model.opt.timestep
    target_every = max(1, int(round(TARGET_PERIOD / dt)))
    load_every = max(1, int(round(LOAD_PERIOD / dt)))
    worst = np.zeros(len(limited))
    for step in range(int(round(DURATION / dt))):
        if step % target_every == 0:
            data.ctrl[:] = rng.uniform(low, high)
        if step % load_every == 0:
            directions = rng.normal(size=(len(tips), 3))
            data.xfrc_applied[:] = 0.0
            data.xfrc_applied[tips, :3] = LOAD * directions / np.linalg.norm(directions, axis=1, keepdims=True)
        mujoco.mj_step(model, data)
        q = data.qpos[adr]
        np.maximum(worst, np.maximum(lower - q, q - upper), out=worst)
    if not np.all(np.isfinite(worst)):
        worst = np.where(np.isfinite(worst), worst, np.inf)
    k = int(np.argmax(worst))
    names = [model.joint(j).name for j in limited]
    beyond = {names[i]: float(worst[i]) for i in range(len(limited)) if worst[i] > BOUND}
    detail = (
        "beyond the bound: " + ", ".join(f"{n} {v:.3g}" for n, v in beyond.items())
        if beyond
        else f"worst {names[k]}; {len(tips)} fingertips x {LOAD:g} N, {DURATION:g} s"
    )
    return [
        Check(
            "load_limits",
            verdict(not beyond),
            f"{fmt(float(worst[k]))} rad",
            bound,
            detail,
            {"excess_rad": {n: float(v) for n, v in zip(names, worst)}, "seed": options.seed},
        )
    ]
