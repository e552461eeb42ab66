"""First touch per world: the contacts MuJoCo C and MuJoCo Warp (CPU device) compute, with multiccd on and off.

    python benchmarks/batch_first_contacts.py

The worlds of tests/batch/test_env.py's equivalence test (16, random servo targets, seed 7): MuJoCo C steps each
world of the batch scene until its first contact, then both engines compute the contacts of that same state,
once with the batch model as built (multiccd off) and once with multiccd on (MuJoCo C 4.0's default). Prints
per world and setting the contact counts and the angle between the two engines' first contact normals. This
is why the batch model turns multiccd off (see svhdesc/compiler/export/batch.py). Not a test: a diagnosis.
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))
os.environ.setdefault("WARP_CACHE_PATH", str(REPO / ".cache" / "warp"))

import mujoco  # noqa: E402

import svhdesc  # noqa: E402

WORLDS, SEED, SECONDS = 16, 7, 1.0
MULTICCD = int(mujoco.mjtDisableBit.mjDSBL_MULTICCD)


def first_touch(model: mujoco.MjModel, ctrl: np.ndarray) -> tuple[int, np.ndarray, np.ndarray] | None:
    """(step, qpos, qvel) of the state whose forward pass finds the first contact, or None within SECONDS."""
    data = mujoco.MjData(model)
    mujoco.mj_resetDataKeyframe(model, data, model.key("home").id)
    data.ctrl[:] = ctrl
    for step in range(int(round(SECONDS / model.opt.timestep))):
        qpos, qvel = data.qpos.copy(), data.qvel.copy()
        mujoco.mj_step(model, data)
        if data.ncon:
            return step, qpos, qvel
    return None


def contacts(model: mujoco.MjModel, qpos: np.ndarray, qvel: np.ndarray, ctrl: np.ndarray) -> dict[str, np.ndarray]:
    """Contact normals of one state: MuJoCo C's and Warp's (rows: contacts)."""
    import mujoco_warp as mjw
    import warp as wp

    data = mujoco.MjData(model)
    data.qpos[:], data.qvel[:], data.ctrl[:] = qpos, qvel, ctrl
    mujoco.mj_forward(model, data)
    c_normals = np.array([c.frame[:3] for c in data.contact[: data.ncon]])
    with wp.ScopedDevice("cpu"):
        warp_model = mjw.put_model(model)
        warp_data = mjw.put_data(model, data, nconmax=int(model.nconmax), njmax=int(model.njmax))
        mjw.forward(warp_model, warp_data)
        count = int(warp_data.nacon.numpy()[0])
        w_normals = warp_data.contact.frame.numpy()[:count, 0].astype(float)
    return {"c": c_normals, "warp": w_normals}


def angle(a: np.ndarray, b: np.ndarray) -> float:
    """Degrees between the first normals of two contact lists (nan if either is empty)."""
    if not len(a) or not len(b):
        return float("nan")
    return float(np.degrees(np.arccos(np.clip(abs(a[0] @ b[0]), -1.0, 1.0))))


def main() -> None:
    import warp as wp

    wp.config.quiet = True
    path = str(svhdesc.get("svh_right").batch_scene_path)
    built = mujoco.MjModel.from_xml_path(path)
    multi = mujoco.MjModel.from_xml_path(path)
    multi.opt.disableflags &= ~MULTICCD
    low, high = built.actuator_ctrlrange.T
    ctrl = np.random.default_rng(SEED).uniform(low, high, (WORLDS, built.nu))
    print(f"{'world':>5} {'step':>5}  {'setting':<13} {'C contacts':>10} {'Warp contacts':>13} {'normal angle':>12}")
    for world in range(WORLDS):
        touch = first_touch(multi, ctrl[world])
        if touch is None:
            continue
        step, qpos, qvel = touch
        for name, model in (("multiccd on", multi), ("as built", built)):
            found = contacts(model, qpos, qvel, ctrl[world])
            print(
                f"{world:>5} {step:>5}  {name:<13} {len(found['c']):>10} {len(found['warp']):>13} "
                f"{angle(found['c'], found['warp']):>11.4f}d"
            )


if __name__ == "__main__":
    main()
