"""Whether the timestep can integrate the model's servos: a build refuses a model that would diverge.

MuJoCo's implicitfast step integrates a position servo's stiffness explicitly and the damping (the joints' own and
the servos' velocity gain) implicitly: v' = (M + h C)^-1 (M v - h K x), x' = x + h v' for small motions about
``home`` (M the joint-space inertia with the armature, C the damping, K each servo's kp on its joint, h the
timestep). The step is stable while the spectral radius of that linear map is at most 1; undamped, that is
omega * h <= 2 for the fastest natural frequency omega. The build refuses a model whose step would grow a
disturbance with its servos STIFFNESS_MARGIN times as stiff (the inertia, hence omega, changes with the pose),
naming the joint whose servo rings fastest on its own inertia and the settings that bring it back. Beyond this
linear test, the build steps the model: SETTLE s holding ``home``, then DRIVE s of random servo targets (a new one
every TARGET_PERIOD s, as ``validate``'s simulate check does for 10 s): a model that MuJoCo finds diverging (a bad
acceleration, a non-finite state) is refused too, naming the joint. Measured: the
tests' mini robot, undamped, its kp scaled, held random targets at omega * h 1.91 and diverged at 1.98; the shipped
variants ring at 0.016 (the SVH) and 0.085 (the UR5's ``wrist_3_joint``); example-robot-data's finger_edu with kp =
effort / 0.1 rad = 10^4 on 10^-4 kg m^2 at 14.6, and Baxter's ``head_pan`` (rated 50 000 N m) at 6.3, both of which
diverged in ``validate`` (mjWARN_BADQACC, 8e6 mrad). ``svhdesc init`` sizes its servos to omega * h <= 0.9 without
counting the damping (compiler/drives.py).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from svhdesc.compiler.assets import Assets
from svhdesc.errors import SvhdescError
from svhdesc.ir import Robot
from svhdesc.model import random_target_start

STIFFNESS_MARGIN = 1.25  # the servos may be this much stiffer (the inertia this much lighter) before the step grows
SETTLE, DRIVE, TARGET_PERIOD = 0.5, 1.0, 0.05  # s: the build's trial run


@dataclass(frozen=True)
class Servos:
    """The linearised servo dynamics at home: inertia M, damping C, stiffness K (nv x nv), the timestep, and the servo
    that rings fastest on its own joint's inertia (name, kp, inertia)."""

    inertia: np.ndarray
    damping: np.ndarray
    stiffness: np.ndarray
    timestep: float
    fastest: tuple[str, float, float]


def servos(model: Any) -> Servos:
    """The model's servo dynamics at its ``home`` keyframe (at qpos0 without one)."""
    import mujoco

    data = mujoco.MjData(model)
    home = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_KEY, "home")
    if home >= 0:
        mujoco.mj_resetDataKeyframe(model, data, home)
    mujoco.mj_forward(model, data)
    inertia = np.zeros((model.nv, model.nv))
    mujoco.mj_fullM(model, data, inertia)
    damping = np.diag(np.asarray(model.dof_damping, dtype=float))
    stiffness = np.zeros((model.nv, model.nv))
    fastest, rate = ("", 0.0, 0.0), 0.0
    for actuator in range(model.nu):
        if int(model.actuator_trntype[actuator]) != int(mujoco.mjtTrn.mjTRN_JOINT):
            continue
        dof = int(model.jnt_dofadr[model.actuator_trnid[actuator, 0]])
        kp = float(model.actuator_gainprm[actuator, 0])
        stiffness[dof, dof] += kp
        damping[dof, dof] += max(-float(model.actuator_biasprm[actuator, 2]), 0.0)
        own = kp / inertia[dof, dof] if inertia[dof, dof] > 0 else math.inf
        if own > rate:
            fastest, rate = (model.actuator(actuator).name, kp, float(inertia[dof, dof])), own
    return Servos(inertia, damping, stiffness, float(model.opt.timestep), fastest)


def growth(servos: Servos, scale: float = 1.0) -> float:
    """The spectral radius of the linearised step with the stiffness scaled by ``scale`` (stable: <= 1)."""
    h, n = servos.timestep, len(servos.inertia)
    if n == 0:
        return 0.0
    solve = np.linalg.solve(servos.inertia + h * servos.damping, np.hstack([servos.stiffness * scale, servos.inertia]))
    sk, sm = solve[:, :n], solve[:, n:]
    step = np.block([[np.eye(n) - h * h * sk, h * sm], [-h * sk, sm]])
    return float(np.max(np.abs(np.linalg.eigvals(step))))


def fastest_servo(model: Any) -> tuple[float, str, float, float]:
    """(omega * timestep of the undamped servos, the servo ringing fastest on its own joint's inertia, its kp, the
    inertia behind it); omega 0 for a model without servos."""
    import scipy.linalg

    found = servos(model)
    if not found.stiffness.any():
        return 0.0, "", 0.0, 0.0
    highest = float(scipy.linalg.eigh(found.stiffness, found.inertia, eigvals_only=True).max())
    return (math.sqrt(max(highest, 0.0)) * found.timestep, *found.fastest)


def _advice(found: Servos) -> str:
    name, kp, inertia = found.fastest
    stable_kp = inertia * (2.0 / found.timestep) ** 2 / STIFFNESS_MARGIN
    return (
        f"The fastest servo, {name} (kp {kp:.4g} on {inertia:.3g} of inertia at home), needs kp <= {stable_kp:.3g} "
        "without damping (arm.kp or hand.kp); or a smaller simulation.timestep, or more joint damping"
    )


def diverges(model: Any) -> tuple[float, int] | None:
    """(the time, the dof) where MuJoCo first finds the model diverging in the trial run, or None. (MuJoCo resets the
    state when it warns, so the time is read before each step.)"""
    import mujoco

    data, low, high = random_target_start(model)
    rng, period = np.random.default_rng(0), max(1, round(TARGET_PERIOD / model.opt.timestep))
    settle = round(SETTLE / model.opt.timestep)
    for step in range(settle + round(DRIVE / model.opt.timestep)):
        if step >= settle and (step - settle) % period == 0:
            data.ctrl[:] = rng.uniform(low, high)
        when, speeds = float(data.time), np.abs(data.qvel)
        mujoco.mj_step(model, data)
        bad = data.warning[int(mujoco.mjtWarning.mjWARN_BADQACC)]
        if bad.number or not (np.isfinite(data.qpos).all() and np.isfinite(data.qvel).all()):
            dof = int(bad.lastinfo) if bad.number and 0 <= bad.lastinfo < model.nv else int(np.argmax(speeds))
            return when, dof
    return None


def _strongest(model: Any, dof: int) -> str:
    """What drives ``dof``: its servo's force limit over the inertia behind it at home, as an acceleration."""
    import mujoco

    data, _, _ = random_target_start(model)
    mujoco.mj_forward(model, data)
    inertia = np.zeros((model.nv, model.nv))
    mujoco.mj_fullM(model, data, inertia)
    joint = int(model.dof_jntid[dof])
    driving = [a for a in range(model.nu) if int(model.actuator_trnid[a, 0]) == joint]
    if not driving:
        return ""
    force = float(max(abs(v) for v in model.actuator_forcerange[driving[0]]))
    kp, behind = float(model.actuator_gainprm[driving[0], 0]), float(inertia[dof, dof])
    return (
        f" Its servo (kp {kp:.4g}, force limit {force:.4g}) can accelerate the {behind:.3g} of inertia behind it at "
        f"{force / behind:.3g} per s^2: rate it lower (joints.{model.joint(joint).name}.effort), soften it (arm.kp "
        "or hand.kp), or step finer (simulation.timestep)"
    )


def servo_problem(model: Any) -> tuple[str, str]:
    """(why the model cannot be simulated, the joint to name); ("", "") if it can: its linearised step grows a
    disturbance with the servos STIFFNESS_MARGIN times as stiff, or the trial run diverges."""
    found = servos(model)
    grows = growth(found, STIFFNESS_MARGIN) if found.stiffness.any() else 0.0
    if grows > 1.0 + 1e-9:
        problem = (
            f"its servos are stiffer than the timestep integrates: {STIFFNESS_MARGIN:g} times as stiff, MuJoCo's step "
            f"would grow a disturbance {grows:.3g} times per step (the model would diverge). {_advice(found)}"
        )
        return problem, found.fastest[0]
    diverged = diverges(model)
    if diverged is not None:
        when, dof = diverged
        joint = model.joint(int(model.dof_jntid[dof])).name
        problem = (
            f"it diverges {when:.3g} s into a trial run (home held {SETTLE:g} s, then random servo targets): MuJoCo "
            f"finds a bad acceleration at joint {joint}.{_strongest(model, dof)}"
        )
        return problem, joint
    return "", ""


def check_servos(robot: Robot, assets: Assets, section: tuple[str, str]) -> Robot:
    """The build's refusal of a model whose servos the timestep cannot integrate (``section``: where arm.kp and
    hand.kp are written); the robot unchanged otherwise."""
    import mujoco

    from svhdesc.compiler.export.mjcf import export_mjcf

    files = {f"assets/{name}": data for name, data in assets.files.items()}
    problem, fastest = servo_problem(mujoco.MjModel.from_xml_string(export_mjcf(robot).decode(), files))
    if problem:
        at = section[1] if fastest in {c.joint for c in robot.channels} else section[0]
        raise SvhdescError(f"{at}: {robot.name}: {problem}")
    return robot
