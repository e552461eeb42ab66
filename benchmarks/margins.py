"""Simulation margins of the built models (issue 8), through the public API only.

1. Coupling: a new random target across each actuator's full ctrlrange every 0.05 s for 10 s; the worst
   |q_coupled - poly(q_channel)| per variant (bound 1e-3 rad).
2. Limits under load: random 50 N forces on every fingertip (new direction every 0.1 s) while the
   targets change; the worst excursion of any limited joint beyond its range (bound 0.01 rad).

    python benchmarks/margins.py [VARIANT...] [--seed N] [--out F.json]
"""

from __future__ import annotations

import argparse
import json
import sys

import numpy as np

import svhdesc

DURATION = 10.0
TARGET_PERIOD = 0.05
LOAD = 50.0  # N
LOAD_PERIOD = 0.1


def _coupling(model, data) -> tuple[np.ndarray, np.ndarray, np.ndarray, list[str]]:  # type: ignore[no-untyped-def]
    import mujoco

    rows = [i for i in range(model.neq) if model.eq_type[i] == mujoco.mjtEq.mjEQ_JOINT and model.eq_obj2id[i] >= 0]
    coupled = np.array([model.jnt_qposadr[model.eq_obj1id[i]] for i in rows], dtype=int)
    leaders = np.array([model.jnt_qposadr[model.eq_obj2id[i]] for i in rows], dtype=int)
    coeffs = np.array([model.eq_data[i, :5] for i in rows]).reshape(-1, 5)
    names = [model.joint(int(model.eq_obj1id[i])).name for i in rows]
    return coupled, leaders, coeffs, names


def run(variant: str, seed: int, loads: bool) -> dict[str, object]:
    import mujoco

    model = svhdesc.load_mujoco(variant)
    data = mujoco.MjData(model)
    home = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_KEY, "home")
    if home >= 0:
        mujoco.mj_resetDataKeyframe(model, data, home)
    rng = np.random.default_rng(seed)
    low, high = model.actuator_ctrlrange.T
    coupled, leaders, coeffs, names = _coupling(model, data)
    limited = [j for j in range(model.njnt) if model.jnt_limited[j]]
    adr = np.array([model.jnt_qposadr[j] for j in limited], dtype=int)
    lo, hi = model.jnt_range[limited].T
    tips = [model.body(i).id for i in range(model.nbody) if model.body(i).name.endswith(("_c", "_t", "_s", "_r", "_q"))]
    dt = model.opt.timestep
    target_every, load_every = int(round(TARGET_PERIOD / dt)), int(round(LOAD_PERIOD / dt))
    worst_coupling = np.zeros(len(names))
    worst_limit = np.zeros(len(limited))
    for step in range(int(round(DURATION / dt))):
        if step % target_every == 0:
            data.ctrl[:] = rng.uniform(low, high)
        if loads and step % load_every == 0:
            data.xfrc_applied[:] = 0.0
            for body in tips:
                direction = rng.normal(size=3)
                data.xfrc_applied[body, :3] = LOAD * direction / np.linalg.norm(direction)
        mujoco.mj_step(model, data)
        q = data.qpos[leaders]
        expected = coeffs[:, 4].copy()
        for k in (3, 2, 1, 0):
            expected = expected * q + coeffs[:, k]
        np.maximum(worst_coupling, np.abs(data.qpos[coupled] - expected), out=worst_coupling)
        qj = data.qpos[adr]
        np.maximum(worst_limit, np.maximum(lo - qj, qj - hi), out=worst_limit)
    joint_names = [model.joint(j).name for j in limited]
    i, k = int(np.argmax(worst_coupling)), int(np.argmax(worst_limit))
    return {
        "variant": variant,
        "loads": loads,
        "coupling_worst_rad": float(worst_coupling[i]),
        "coupling_worst_joint": names[i],
        "limit_excess_worst_rad": float(worst_limit[k]),
        "limit_excess_worst_joint": joint_names[k],
    }


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("variants", nargs="*")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--out", default=None)
    args = parser.parse_args()
    results = []
    for variant in args.variants or svhdesc.variants():
        for loads in (False, True):
            result = run(variant, args.seed, loads)
            results.append(result)
            print(
                f"{variant:<15} loads={'50N' if loads else 'off':<4} coupling {result['coupling_worst_rad']:.2e} rad "
                f"({result['coupling_worst_joint']})  limit excess {result['limit_excess_worst_rad']:.2e} rad "
                f"({result['limit_excess_worst_joint']})",
                flush=True,
            )
    if args.out:
        with open(args.out, "w") as handle:
            json.dump(results, handle, indent=2)
    ok = all(r["coupling_worst_rad"] <= 1e-3 and r["limit_excess_worst_rad"] <= 0.01 for r in results)
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
