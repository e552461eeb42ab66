"""Whether the timestep can integrate the model's servos: a build refuses a model that would diverge.

MuJoCo's implicitfast step integrates a position servo's stiffness explicitly and the damping (the joints' own and
the servos' velocity gain) implicitly: v' = (M + h C)^-1 (M v - h K x), x' = x + h v' for small motions about
``home`` (M the joint-space inertia with the armature, C the damping, K each servo's kp on its joint, h the
timestep). The step is stable while the spectral radius of that linear map is at most 1; undamped, that is
omega * h <= 2 for the fastest natural frequency omega. The build refuses a model whose step would grow a
disturbance with its servos STIFFNESS_MARGIN times as stiff (the inertia, hence omega, changes with the pose),
naming the joint whose servo rings fastest on its own inertia and the settings that bring it back. Beyond this
linear test, the build steps the model through ``validate``'s simulate run itself (``svhdesc.model.run_random_targets``:
10 s from ``home``, a random servo target every 0.05 s, seed 0, validate's default): a model that MuJoCo finds
diverging there (a bad acceleration, velocity or position, a non-finite state) is refused, naming the time, the joint
and the settings that help, as validate words it; so validate's default run never finds a divergence in a model the
build passed (iCub's arms against elliptic-cone contacts diverge at 8.08 s, which a shorter trial run missed). The
run's result is remembered by content in the probes' cache (``svhdesc.compiler.probes.cache``): a rebuild of an
unchanged model does not step it again. Measured: the
tests' mini robot, undamped, its kp scaled, held random targets at omega * h 1.91 and diverged at 1.98; the shipped
variants ring at 0.016 (the SVH) and 0.085 (the UR5's ``wrist_3_joint``); example-robot-data's finger_edu with kp =
effort / 0.1 rad = 10^4 on 10^-4 kg m^2 at 14.6, and Baxter's ``head_pan`` (rated 50 000 N m) at 6.3, both of which
diverged in ``validate`` (mjWARN_BADQACC, 8e6 mrad). ``svhdesc init`` sizes its servos to omega * h <= 0.9 without
counting the damping (compiler/drives.py).
"""

from __future__ import annotations

import inspect
import math
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from svhdesc.compiler.assets import Assets
from svhdesc.compiler.probes.cache import cache_dir, content_key, remembered
from svhdesc.errors import SvhdescError
from svhdesc.ir import Robot
from svhdesc.model import (
    RANDOM_TARGET_PERIOD,
    RANDOM_TARGET_SECONDS,
    RANDOM_TARGET_SEED,
    Divergence,
    random_target_start,
    run_random_targets,
    velocity_servos,
)

STIFFNESS_MARGIN = 1.25  # the servos may be this much stiffer (the inertia this much lighter) before the step grows


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
        kp = max(-float(model.actuator_biasprm[actuator, 1]), 0.0)  # a position servo's; a velocity servo has none
        stiffness[dof, dof] += kp
        damping[dof, dof] += max(-float(model.actuator_biasprm[actuator, 2]), 0.0)
        own = kp / inertia[dof, dof] if inertia[dof, dof] > 0 else math.inf
        if kp > 0 and own > rate:
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


def diverges(model: Any) -> Divergence | None:
    """Where MuJoCo first finds the model diverging in validate's simulate run with its default seed, or None."""
    return run_random_targets(model, RANDOM_TARGET_SEED, until_diverged=True).diverged


def _remembered_diverges(mjcf: bytes, assets: Assets) -> Callable[[Any], Divergence | None]:
    """``diverges``, remembered by content: the MJCF states everything the run steps, the plan and the code what it
    does."""
    plan = repr((RANDOM_TARGET_SECONDS, RANDOM_TARGET_PERIOD, RANDOM_TARGET_SEED)).encode()
    code = Path(__file__).read_bytes() + inspect.getsource(run_random_targets).encode()
    key = content_key((plan, code, mjcf), assets.files)

    def encode(found: Divergence | None) -> Any:  # [] for none: the cache reads a null value as no entry
        return [] if found is None else [found.time, found.joint, found.contacts]

    def decode(entry: Any) -> Divergence | None:
        return None if entry == [] else Divergence(float(entry[0]), str(entry[1]), int(entry[2]))

    return lambda model: remembered(cache_dir("trial_run"), key, lambda: diverges(model), encode, decode)


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
    gain, behind = float(model.actuator_gainprm[driving[0], 0]), float(inertia[dof, dof])
    name = "kv" if model.joint(joint).name in velocity_servos(model) else "kp"
    return (
        f" Its servo ({name} {gain:.4g}, force limit {force:.4g}) can accelerate the {behind:.3g} of inertia behind it"
        f" at {force / behind:.3g} per s^2."
    )


def servo_problem(model: Any, trial: Callable[[Any], Divergence | None] = diverges) -> tuple[str, str]:
    """(why the model cannot be simulated, the joint to name); ("", "") if it can: its linearised step grows a
    disturbance with the servos STIFFNESS_MARGIN times as stiff, or ``trial`` (validate's simulate run) diverges."""
    found = servos(model)
    grows = growth(found, STIFFNESS_MARGIN) if found.stiffness.any() else 0.0
    if grows > 1.0 + 1e-9:
        problem = (
            f"its servos are stiffer than the timestep integrates: {STIFFNESS_MARGIN:g} times as stiff, MuJoCo's step "
            f"would grow a disturbance {grows:.3g} times per step (the model would diverge). {_advice(found)}"
        )
        return problem, found.fastest[0]
    diverged = trial(model)
    if diverged is None:
        return "", ""
    joint = model.joint(diverged.joint).id if diverged.joint != "?" else -1
    dof = int(model.jnt_dofadr[joint]) if joint >= 0 else -1
    problem = (
        f"validate's simulate run ({RANDOM_TARGET_SECONDS:g} s of random servo targets from home, seed "
        f"{RANDOM_TARGET_SEED}) {diverged}.{_strongest(model, dof) if dof >= 0 else ''}"
    )
    return problem, diverged.joint


def check_servos(robot: Robot, assets: Assets, section: tuple[str, str]) -> Robot:
    """The build's refusal of a model whose servos the timestep cannot integrate (``section``: where arm.kp and
    hand.kp are written); the robot unchanged otherwise."""
    import mujoco

    from svhdesc.compiler.export.mjcf import export_mjcf

    files = {f"assets/{name}": data for name, data in assets.files.items()}
    mjcf = export_mjcf(robot)
    model = mujoco.MjModel.from_xml_string(mjcf.decode(), files)
    problem, fastest = servo_problem(model, _remembered_diverges(mjcf, assets))
    if problem:
        at = section[1] if fastest in {c.joint for c in robot.channels} else section[0]
        raise SvhdescError(f"{at}: {robot.name}: {problem}")
    return robot
