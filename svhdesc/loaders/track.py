"""One second of the same servo targets in any engine that loads a built variant, recorded for comparison.

The reference is MuJoCo C on the MJCF, with its own position servos. Every run has gravity and contacts off (the
MJCF compensates gravity through its actuators, which no other format carries; contact is not what is compared):
what is compared is the articulation, the servos, the joint damping and armature, and the couplings. An engine runs
the servo the MJCF defines, ``tau = clip(kp (target - q) - kv qdot, -effort, effort)``, as joint torques where its
own drives cannot clip (Newton's Featherstone applies no effort limit).

Runs in whichever environment has the engine: ``python -m svhdesc.loaders.track ENGINE FILE VARIANT [--solver S]
[--plan PLAN.json]`` prints one JSON line: the run, or ``{"error": ...}`` naming what the engine could not read.
"""

from __future__ import annotations

import argparse
import contextlib
import json
import re
import subprocess
import sys
import tempfile
from dataclasses import asdict, dataclass, field
from importlib import metadata
from typing import Any

import numpy as np

SECONDS = 1.0
SAMPLES = 100  # recorded at equal intervals over the run
FRACTION = 0.6  # each servo's target, as a fraction of its range
RUN_TIMEOUT = 600  # s, one run in another environment


@dataclass
class Run:
    engine: str
    version: str
    file: str
    solver: str
    dof: int = 0
    mimics: list[tuple[str, str, float, float]] = field(default_factory=list)  # follower, leader, offset, ratio
    mass: float = 0.0
    joints: list[str] = field(default_factory=list)
    q: list[list[float]] = field(default_factory=list)  # SAMPLES x joints
    error: str | None = None


def servo_plan(mjcf: str) -> dict[str, Any]:
    """The servos (joint, target, kp, kv, effort) and every joint's armature, as MuJoCo compiles the MJCF."""
    import mujoco

    model = mujoco.MjModel.from_xml_path(mjcf)
    servos = []
    for a in range(model.nu):
        low, high = (float(v) for v in model.actuator_ctrlrange[a])
        servos.append(
            {
                "joint": model.joint(model.actuator_trnid[a, 0]).name,
                "target": low + FRACTION * (high - low),
                "kp": float(model.actuator_gainprm[a, 0]),
                "kv": float(-model.actuator_biasprm[a, 2]),
                "effort": float(model.actuator_forcerange[a, 1]),
            }
        )
    armature = {model.joint(j).name: float(model.dof_armature[model.jnt_dofadr[j]]) for j in range(model.njnt)}
    timestep = float(model.opt.timestep)
    return {"servos": servos, "armature": armature, "timestep": timestep}


def _recorded(steps: int) -> set[int]:
    """The steps after which a sample is taken (SAMPLES of them at equal intervals; none in a run of no step)."""
    return {round(steps * (i + 1) / SAMPLES) for i in range(SAMPLES)} if steps else set()


def run_mujoco(path: str, plan: dict[str, Any], seconds: float = SECONDS) -> Run:
    """MuJoCo (any version) on the MJCF with its own position servos."""
    import mujoco

    return _servo_run(
        mujoco.MjModel.from_xml_path(path), Run("mujoco", mujoco.__version__, "mjcf", "MuJoCo C"), plan, seconds
    )


def run_mjlab(path: str, plan: dict[str, Any], seconds: float = SECONDS) -> Run:
    """mjlab's entity of the variant whose MJCF is ``path`` (svhdesc.mjlab.entity: its batch model, with the solver
    options mjlab sets on the scene's model), compiled by mjlab, stepped in MuJoCo C."""
    from pathlib import Path

    from mjlab.entity import Entity

    from svhdesc.mjlab.entity import built, mujoco_cfg, robot_cfg

    folder = Path(path).parent
    model = Entity(robot_cfg(folder)).spec.compile()
    mujoco_cfg(built(folder)).apply(model)
    return _servo_run(model, Run("mjlab", _version("mjlab"), "mjcf", "MuJoCo C"), plan, seconds)


def _servo_run(model: Any, run: Run, plan: dict[str, Any], seconds: float) -> Run:
    """``model`` from qpos0, gravity and contacts off, each servo at the plan's target, recorded into ``run``."""
    import mujoco

    model.opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_CONTACT
    model.opt.gravity[:] = 0.0
    data = mujoco.MjData(model)
    for servo in plan["servos"]:
        data.actuator(servo["joint"]).ctrl = servo["target"]
    run.joints = [model.joint(j).name for j in range(model.njnt)]
    run.dof, run.mass = model.nv, float(np.sum(model.body_mass))
    for e in range(model.neq):
        if model.eq_type[e] == mujoco.mjtEq.mjEQ_JOINT:
            names = model.joint(model.eq_obj1id[e]).name, model.joint(model.eq_obj2id[e]).name
            run.mimics.append((*names, float(model.eq_data[e, 0]), float(model.eq_data[e, 1])))
    address = [model.jnt_qposadr[j] for j in range(model.njnt)]
    steps = round(seconds / model.opt.timestep)
    recorded = _recorded(steps)
    for k in range(steps):
        mujoco.mj_step(model, data)
        if k + 1 in recorded:
            run.q.append([float(data.qpos[a]) for a in address])
    return run


def newton_mimics(builder: Any, names: list[str], sparse: bool = False) -> list[tuple[str, str, float, float]]:
    """The couplings a Newton model builder holds: its joint mimics (what every solver enforces) and, with ``sparse``,
    the MJCF importer's mimic constraints, which only SolverMuJoCo enforces (as MuJoCo equalities)."""
    leaders, coeffs = builder.joint_mimic_joint, builder.joint_mimic_coeffs
    found = [
        (names[j], names[leaders[j]], float(coeffs[j][0]), float(coeffs[j][1]))
        for j in range(len(names))
        if leaders[j] >= 0
    ]
    if sparse:
        pairs = zip(*(getattr(builder, f"constraint_mimic_{k}") for k in ("joint0", "joint1", "coef0", "coef1")))
        found += [(names[a], names[b], float(c0), float(c1)) for a, b, c0, c1 in pairs]
    return found


def run_newton(
    path: str, file: str, plan: dict[str, Any], solver: str = "featherstone", seconds: float = SECONDS
) -> Run:
    """Newton (Warp's CPU) with ``solver``: featherstone, or mujoco (SolverMuJoCo on MuJoCo C, newton[sim]). What it
    holds is read from the importer's builder; a run of 0 s stops there (no finalize: the hulls' adjacency alone
    takes seconds)."""
    import newton

    from svhdesc.loaders.newton import builder_for, joint_names

    run = Run("newton", newton.__version__, file, solver)
    armature = plan["armature"] if file == "urdf" else None  # the URDF has none: the MJCF's
    builder = builder_for(path, file, armature, gravity=0.0, promote=solver != "mujoco")
    names = joint_names(builder.joint_label)
    run.mimics = newton_mimics(builder, names, sparse=solver == "mujoco")
    run.dof, run.mass = int(builder.joint_dof_count), float(np.sum(builder.body_mass))
    if seconds > 0:
        _track(newton, builder.finalize(device="cpu"), names, plan, solver, seconds, run)
    return run


def _track(
    newton: Any, model: Any, names: list[str], plan: dict[str, Any], solver: str, seconds: float, run: Run
) -> None:
    """Step ``model`` for ``seconds`` with the plan's servos as joint torques, recording into ``run``."""
    q_start, qd_start = model.joint_q_start.numpy(), model.joint_qd_start.numpy()
    movable = [j for j in range(len(names)) if qd_start[j + 1] > qd_start[j]]
    run.joints = [names[j] for j in movable]
    servos = [(qd_start[names.index(s["joint"])], q_start[names.index(s["joint"])], s) for s in plan["servos"]]
    zero = np.zeros(model.joint_dof_count, dtype=np.float32)
    model.joint_target_ke.assign(zero)  # the servo runs as torques below
    model.joint_target_kd.assign(zero)
    step = _newton_solver(newton, model, solver)
    state, after, control = model.state(), model.state(), model.control()
    newton.eval_fk(model, model.joint_q, model.joint_qd, state)
    steps = round(seconds / plan["timestep"])
    recorded = _recorded(steps)
    for k in range(steps):
        q, qd = state.joint_q.numpy(), state.joint_qd.numpy()
        torque = np.zeros(model.joint_dof_count)
        for dof, coordinate, s in servos:
            tau = s["kp"] * (s["target"] - q[coordinate]) - s["kv"] * qd[dof]
            torque[dof] = np.clip(tau, -s["effort"], s["effort"])
        control.joint_f.assign(torque.astype(np.float32))
        state.clear_forces()
        step(state, after, control, plan["timestep"])
        state, after = after, state
        if k + 1 in recorded:
            q = state.joint_q.numpy()
            run.q.append([float(q[q_start[j]]) for j in movable])


def _newton_solver(newton: Any, model: Any, name: str) -> Any:
    if name == "featherstone":
        solver = newton.solvers.SolverFeatherstone(model)
    elif name == "mujoco":
        solver = newton.solvers.SolverMuJoCo(model, use_mujoco_cpu=True, disable_contacts=True)
    else:
        raise ValueError(f"solver must be featherstone or mujoco, not {name!r}")
    return lambda state, after, control, dt: solver.step(state, after, control, None, dt)


def run(engine: str, file: str, path: str, plan: dict[str, Any], solver: str, seconds: float = SECONDS) -> Run:
    """One run; an engine that cannot read the file gives a Run whose ``error`` says why, in one line."""
    try:
        if engine == "mujoco":
            return run_mujoco(path, plan, seconds)
        if engine == "mjlab":
            return run_mjlab(path, plan, seconds)
        return run_newton(path, file, plan, solver, seconds)
    except Exception as exc:  # the engine's own reason, whatever it raises, is the table's line
        reason = re.sub(r"pxrInternal_v\w+?__pxrReserved__::", "", " ".join(str(exc).split())) or type(exc).__name__
        return Run(engine, _version(engine), file, solver, error=f"{type(exc).__name__}: {reason}"[:300])


def run_in(
    python: str,
    engine: str,
    file: str,
    path: str,
    plan: dict[str, Any],
    solver: str = "featherstone",
    seconds: float = SECONDS,
) -> Run:
    """``run`` in another environment (its interpreter ``python``, svhdesc installed there); a run that gives no
    result says why in ``error`` (the interpreter missing, the process dying: its last line)."""
    with tempfile.NamedTemporaryFile("w", suffix=".json") as stream:
        json.dump(plan, stream)
        stream.flush()
        command = [python, "-m", "svhdesc.loaders.track", engine, file, path, "--plan", stream.name, "--solver", solver]
        command += ["--seconds", str(seconds)]
        try:
            done = subprocess.run(command, capture_output=True, text=True, timeout=RUN_TIMEOUT)
        except (OSError, subprocess.TimeoutExpired) as exc:
            return Run(engine, "absent", file, solver, error=f"{type(exc).__name__}: {exc}"[:300])
    lines = [line for line in done.stdout.splitlines() if line.startswith("{")]
    if done.returncode != 0 or not lines:
        last = (done.stderr.strip().splitlines() or [f"exit {done.returncode}"])[-1]
        return Run(engine, "unknown", file, solver, error=f"{python} exited {done.returncode}: {last}"[:300])
    return Run(**json.loads(lines[-1]))


@dataclass(frozen=True)
class Figures:
    """A run against the reference, joint by joint by name."""

    deviation: float  # rad, the largest |q - q_reference| over every joint and sample
    final: float  # rad, the same at the end of the run
    residual: float  # rad, the largest |q_follower - (offset + ratio q_leader)| of the spec's couplings
    mimics_kept: int  # the engine's couplings that are the spec's (follower, leader, ratio to 1e-6)


def compare(reference: Run, other: Run, spec: list[tuple[str, str, float, float]]) -> Figures:
    """``other`` against ``reference``; ``spec``: (follower, leader, offset, ratio) of every coupling."""
    index = [other.joints.index(name) for name in reference.joints]
    q = np.asarray(other.q)[:, index]
    gap = np.abs(q - np.asarray(reference.q))
    position = {name: i for i, name in enumerate(reference.joints)}
    residual = max(
        (
            float(np.max(np.abs(q[:, position[f]] - offset - ratio * q[:, position[leader]])))
            for f, leader, offset, ratio in spec
        ),
        default=0.0,
    )
    wanted = {(f, leader): ratio for f, leader, _, ratio in spec}
    kept = sum(
        1
        for f, leader, _, ratio in other.mimics
        if (f, leader) in wanted and abs(ratio - wanted[(f, leader)]) <= 1e-6 * abs(ratio)
    )
    return Figures(float(gap.max()), float(gap[-1].max()), residual, kept)


def _version(engine: str) -> str:
    try:
        return metadata.version(engine)
    except metadata.PackageNotFoundError:
        return "absent"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m svhdesc.loaders.track")
    parser.add_argument("engine", choices=("mujoco", "mjlab", "newton"))
    parser.add_argument("file", choices=("mjcf", "urdf", "usd"))
    parser.add_argument("path")
    parser.add_argument("--plan", required=True, help="the servo plan (JSON), from servo_plan on the MJCF")
    parser.add_argument("--solver", default="featherstone")
    parser.add_argument("--seconds", type=float, default=SECONDS, help="how long to run (0: load only)")
    args = parser.parse_args(argv)
    with open(args.plan) as stream:
        plan = json.load(stream)
    with contextlib.redirect_stdout(sys.stderr):  # engines' own messages (Warp's) go to stderr
        result = run(args.engine, args.file, args.path, plan, args.solver, args.seconds)
    print(json.dumps(asdict(result)))
    return 0


if __name__ == "__main__":
    sys.exit(main())
