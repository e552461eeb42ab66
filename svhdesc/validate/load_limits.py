"""Limits hold under load: random forces on every fingertip while the targets keep changing.

A servo weaker than the load lets the finger hit its limit; the limit constraint must stop it within BOUND
(0.01 rad for a hinge, BOUND_SLIDE for a slide joint: MuJoCo limits are soft, so too soft a solreflimit, or too
fast a joint, and it goes through). The fingertips are the configuration's hand.fingertips (any robot's hand or
gripper), an SVH's distal links without one.

The load is the robot's own: on each fingertip, LOAD_FACTOR times the force its weakest hand drive exerts there
(the actuator's force limit over its lever from the joint axis to the fingertip's centre of mass at ``home``; a
slide joint's force as it is), at most LOAD_MAX; the config's ``validate.tip_load`` (N) where it gives one. A
finger no drive pushes (no force limit) gets LOAD_MAX. Twice its drive overpowers the servo and presses the finger
into its limits; far more than that is not a load its drive could ever meet at the fingertip, and a MuJoCo limit,
whose stiffness scales with the moving mass, gives way to it on a light finger. The run stops at the first
non-finite state or MuJoCo warning and names the joint that ran away and the contacts at that moment.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from svhdesc.model import couplings, warning_counts
from svhdesc.validate.handsim import hand_parts
from svhdesc.validate.options import Options
from svhdesc.validate.pair import ModelPair
from svhdesc.validate.report import Check, fmt, not_run, skipped, verdict
from svhdesc.validate.simulate import random_target_start

DURATION = 10.0  # s
TARGET_PERIOD = 0.05  # s between new random targets
LOAD_FACTOR = 2.0  # x the drive's own force at the fingertip ...
LOAD_MAX = 50.0  # ... at most, N (the SVH's former fixed load)
LOAD_PERIOD = 0.1  # s between new random directions
BOUND = 0.01  # rad beyond a hinge's limit
BOUND_SLIDE = 0.001  # m beyond a slide's limit
RUNAWAY = 50.0  # x the bound beyond a limit: the joint has gone through it, the run is stopped there


def tip_loads(model: Any, tips: list[int], hand_joints: set[str]) -> list[float]:
    """Each fingertip's load (N): LOAD_FACTOR x its weakest hand drive's force there, at most LOAD_MAX."""
    import mujoco

    data = mujoco.MjData(model)
    home = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_KEY, "home")
    if home >= 0:
        mujoco.mj_resetDataKeyframe(model, data, home)
    mujoco.mj_forward(model, data)
    actuator_of = {int(model.actuator_trnid[a, 0]): a for a in range(model.nu)}
    leader = {model.joint(c.joint).id: model.joint(c.leader).id for c in couplings(model)}
    loads = []
    for tip in tips:
        forces = [LOAD_MAX / LOAD_FACTOR]
        for j in _chain(model, tip):
            a = actuator_of.get(j, actuator_of.get(leader.get(j, -1)))
            if a is not None and model.joint(j).name in hand_joints and model.actuator_forcelimited[a]:
                forces.append(_drive_force(model, data, tip, j, a))
        loads.append(LOAD_FACTOR * min(forces))
    return loads


def _chain(model: Any, body: int) -> list[int]:
    """The joints between ``body`` and the world, ``body``'s own first."""
    joints = []
    while body > 0:
        joints += range(model.body_jntadr[body], model.body_jntadr[body] + model.body_jntnum[body])
        body = int(model.body_parentid[body])
    return joints


def _drive_force(model: Any, data: Any, tip: int, joint: int, actuator: int) -> float:
    """The force (N) actuator's force limit exerts at ``tip``'s centre of mass through ``joint``."""
    import mujoco

    effort = float(np.abs(model.actuator_forcerange[actuator]).max() * abs(model.actuator_gear[actuator, 0]))
    if int(model.jnt_type[joint]) == int(mujoco.mjtJoint.mjJNT_SLIDE):
        return effort
    lever = float(np.linalg.norm(np.cross(data.xipos[tip] - data.xanchor[joint], data.xaxis[joint])))
    return effort / lever if lever > 1e-6 else LOAD_MAX / LOAD_FACTOR


def _runaway(model: Any, data: Any, joint: str | None, speeds: np.ndarray, pairs: np.ndarray) -> str:
    """What ran away: ``joint`` (one through its limit), else the fastest joint of the last sound step (MuJoCo resets
    the state when it warns); its speed, MuJoCo's warnings and the body pairs in contact in that step."""
    dof = int(np.argmax(np.nan_to_num(np.abs(speeds), nan=np.inf))) if model.nv else 0
    if joint is None:
        joint = model.joint(int(model.dof_jntid[dof])).name if model.nv else "-"
    else:
        dof = int(model.jnt_dofadr[model.joint(joint).id])
    warned = ", ".join(name.removeprefix("mjWARN_") for name in warning_counts(data))
    names = sorted(
        {f"{model.body(int(model.geom_bodyid[a])).name}/{model.body(int(model.geom_bodyid[b])).name}" for a, b in pairs}
    )
    touching = f"; in contact: {', '.join(names[:6])}" + (" ..." if len(names) > 6 else "") if names else ""
    text = f"{joint} ran away ({abs(speeds[dof]):.3g} rad/s)" if model.nv else f"{joint} ran away"
    return text + (f", MuJoCo warns {warned}" if warned else "") + touching


def _loaded_run(
    model: Any, seed: int, limited: list[int], tips: list[int], loads: np.ndarray
) -> tuple[np.ndarray, str]:
    """Random targets and fingertip loads for DURATION s: each limited joint's worst excess beyond its range, and
    how the run diverged (empty if it did not)."""
    import mujoco

    data, rng, low, high = random_target_start(model, seed)
    adr = np.array([model.jnt_qposadr[j] for j in limited], dtype=int)
    lower, upper = model.jnt_range[limited].T
    dt = model.opt.timestep
    target_every = max(1, int(round(TARGET_PERIOD / dt)))
    load_every = max(1, int(round(LOAD_PERIOD / dt)))
    worst = np.zeros(len(limited))
    allowed = np.where(model.jnt_type[limited] == int(mujoco.mjtJoint.mjJNT_SLIDE), BOUND_SLIDE, BOUND)
    speeds, pairs = data.qvel.copy(), np.zeros((0, 2), dtype=int)
    for step in range(int(round(DURATION / dt))):
        if step % target_every == 0:
            data.ctrl[:] = rng.uniform(low, high)
        if step % load_every == 0:
            directions = rng.normal(size=(len(tips), 3))
            data.xfrc_applied[:] = 0.0
            data.xfrc_applied[tips, :3] = loads[:, None] * directions / np.linalg.norm(directions, axis=1)[:, None]
        mujoco.mj_step(model, data)
        q = data.qpos[adr]
        excess = np.where(np.isfinite(q), np.maximum(lower - q, q - upper), np.inf)
        np.maximum(worst, excess, out=worst)
        through = np.flatnonzero(excess > RUNAWAY * allowed)
        if warning_counts(data) or not np.isfinite(data.qvel).all() or len(through):
            culprit = model.joint(limited[int(through[0])]).name if len(through) else None
            if culprit is not None:
                speeds, pairs = data.qvel.copy(), np.array(data.contact.geom[: data.ncon]).reshape(-1, 2)
            return worst, f"diverged at t = {step * dt:.3f} s: {_runaway(model, data, culprit, speeds, pairs)}"
        speeds, pairs = data.qvel.copy(), np.array(data.contact.geom[: data.ncon]).reshape(-1, 2)
    return worst, ""


def check_load_limits(pair: ModelPair, options: Options) -> list[Check]:
    import mujoco

    bound = f"<= {BOUND:g} rad (slide: {BOUND_SLIDE * 1e3:g} mm) beyond a limit"
    if pair.model is None:
        return [not_run("load_limits", "the MJCF does not compile", bound)]
    model = pair.model
    hand = hand_parts(pair)
    limited = [j for j in range(model.njnt) if model.jnt_limited[j]]
    if not hand.tips:
        return [skipped("load_limits", "no fingertips", bound)]
    if not limited:
        return [skipped("load_limits", "no limited joints", bound)]
    followers = {c.joint for c in couplings(model) if c.leader in hand.channels}
    given = pair.configuration.settings.validate.tip_load if pair.configuration is not None else None
    if given is not None:  # the config's validate.tip_load
        loads = np.full(len(hand.tips), float(given))
    else:
        loads = np.array(tip_loads(model, hand.tips, set(hand.channels) | followers))
    worst, diverged = _loaded_run(model, options.seed, limited, hand.tips, loads)
    allowed = np.where(model.jnt_type[limited] == int(mujoco.mjtJoint.mjJNT_SLIDE), BOUND_SLIDE, BOUND)
    names = [model.joint(j).name for j in limited]
    ratio = worst / allowed
    k = int(np.argmax(ratio))
    beyond = {names[i]: float(worst[i]) for i in range(len(limited)) if worst[i] > allowed[i]}
    loaded = f"{len(hand.tips)} fingertips x {fmt(float(loads.min()))}..{fmt(float(loads.max()))} N, {DURATION:g} s"
    detail = (
        "; ".join(
            part
            for part in (
                diverged,
                "beyond the bound: " + ", ".join(f"{n} {v:.3g}" for n, v in beyond.items()) if beyond else "",
            )
            if part
        )
        or f"worst {names[k]}; {loaded}"
    )
    return [
        Check(
            "load_limits",
            verdict(not beyond and not diverged),
            f"{fmt(float(worst[k]))} {'m' if allowed[k] == BOUND_SLIDE else 'rad'}",
            bound,
            detail,
            {
                "excess": {n: float(v) for n, v in zip(names, worst, strict=True)},
                "loads_n": {model.body(b).name: float(f) for b, f in zip(hand.tips, loads, strict=True)},
                "diverged": diverged,
                "seed": options.seed,
            },
        )
    ]
