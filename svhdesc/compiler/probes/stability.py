"""Whether the timestep can integrate the model's servos: a build refuses a model that would diverge.

MuJoCo integrates a position servo's stiffness explicitly, so the servos on the mass matrix ring at the natural
frequencies omega of the generalised eigenproblem K v = omega^2 M v (K: each servo's kp on its joint, M: the joint
space inertia at ``home``, armature included), and the step is unstable once omega * timestep passes 2. The build
refuses above MAX_OMEGA_DT, naming the joint whose servo rings fastest on its own inertia and the settings that
bring it back (its kp, the timestep). Measured: the shipped variants 0.016 (the SVH) and 0.085 (the UR5's
``wrist_3_joint``); example-robot-data's finger_edu with kp = effort / 0.1 rad = 10^4 on 10^-4 kg m^2: 14.6, and
Baxter's ``head_pan`` (rated 50 000 N m): 6.3, both of which diverged in ``validate`` (mjWARN_BADQACC, 8e6 mrad).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from svhdesc.compiler.assets import Assets
from svhdesc.errors import SvhdescError
from svhdesc.ir import Robot

MAX_OMEGA_DT = 1.0


def fastest_servo(model: Any) -> tuple[float, str, float, float]:
    """(omega * timestep of the whole model, the servo ringing fastest on its own joint's inertia, that servo's kp,
    the inertia behind it); omega 0 for a model without servos. Read at the ``home`` keyframe where there is one."""
    import mujoco
    import scipy.linalg

    data = mujoco.MjData(model)
    home = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_KEY, "home")
    if home >= 0:
        mujoco.mj_resetDataKeyframe(model, data, home)
    mujoco.mj_forward(model, data)
    inertia = np.zeros((model.nv, model.nv))
    mujoco.mj_fullM(model, data, inertia)
    stiffness = np.zeros((model.nv, model.nv))
    worst = (0.0, "", 0.0, 0.0)
    for actuator in range(model.nu):
        if int(model.actuator_trntype[actuator]) != int(mujoco.mjtTrn.mjTRN_JOINT):
            continue
        dof = int(model.jnt_dofadr[model.actuator_trnid[actuator, 0]])
        kp = float(model.actuator_gainprm[actuator, 0])
        stiffness[dof, dof] += kp
        own = kp / inertia[dof, dof] if inertia[dof, dof] > 0 else math.inf
        if own > worst[0]:
            worst = (own, model.actuator(actuator).name, kp, float(inertia[dof, dof]))
    if not stiffness.any():
        return 0.0, "", 0.0, 0.0
    highest = float(scipy.linalg.eigh(stiffness, inertia, eigvals_only=True).max())
    return math.sqrt(max(highest, 0.0)) * float(model.opt.timestep), worst[1], worst[2], worst[3]


def servo_problem(model: Any) -> tuple[str, str]:
    """(why the timestep cannot integrate the model's servos, the fastest servo's name); ("", "") if it can."""
    omega_dt, name, kp, inertia = fastest_servo(model)
    if omega_dt <= MAX_OMEGA_DT:
        return "", ""
    timestep = float(model.opt.timestep)
    stable_kp = inertia * (MAX_OMEGA_DT / timestep) ** 2
    problem = (
        f"its servos ring faster than the timestep resolves (omega * timestep {omega_dt:.3g} > {MAX_OMEGA_DT:g}): the "
        f"model would diverge. The fastest, {name} (kp {kp:.4g} on {inertia:.3g} of inertia at home), needs kp <= "
        f"{stable_kp:.3g} (arm.kp or hand.kp), or a timestep <= {timestep * MAX_OMEGA_DT / omega_dt:.2g} s "
        "(simulation.timestep)"
    )
    return problem, name


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
