"""Build and simulation speed, measured in one run on this machine (not a test: machines are noisy).

    python benchmarks/bench.py            # prints the figures and the ratios to the targets, writes
                                          # docs/results/build.md
    python benchmarks/bench.py --quick    # the same without (c) on an empty hull cache (minutes)

(a) cold build of the three variants (empty hull cache, empty output directory),
(b) warm build: unchanged sources (up-to-date check) and forced (--force: full rebuild, cache hits),
(c) --check on a clean clone: it trusts nothing in generated/, so with an empty hull cache it decomposes every
    collision mesh again; then the same with the hull cache it filled (what a developer's machine sees),
(d) simulation speed of ur5_svh_right pressing its index fingertip on a fixed surface in the `test`
    pose, as realtime factor at the model's own timestep, and as a ratio to the thesis model
    (../shared/peers seed_svh_ur5_mujoco) in the same scene, measured in the same run.
"""

from __future__ import annotations

import argparse
import os
import re
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import mujoco
import numpy as np

REPO = Path(__file__).resolve().parents[1]
PEERS = REPO.parent / "shared" / "peers"
VARIANT = "ur5_svh_right"
SETTLE_STEPS = 1000
TIMED_SECONDS = 10.0

sys.path.insert(0, str(REPO / "benchmarks"))
from results import write  # noqa: E402


def timed(args: list[str], cwd: Path, cache: Path) -> tuple[float, str]:
    env = {**os.environ, "SVHDESC_CACHE": str(cache)}
    start = time.perf_counter()
    result = subprocess.run(
        [sys.executable, "-m", "svhdesc.cli", *args], cwd=cwd, env=env, capture_output=True, text=True
    )
    elapsed = time.perf_counter() - start
    if result.returncode != 0:
        raise SystemExit(f"{' '.join(args)} failed:\n{result.stderr}")
    print(f"  svhdesc {' '.join(args)}: {elapsed:.1f} s", flush=True)  # progress: a cold build takes minutes
    counts = re.search(r"decompositions: .*", result.stderr)
    return elapsed, counts.group(0) if counts else ""


def tip_points(model: mujoco.MjModel, data: mujoco.MjData, body: int) -> np.ndarray:
    points = []
    for g in range(model.ngeom):
        if model.geom_bodyid[g] != body or not (model.geom_contype[g] or model.geom_conaffinity[g]):
            continue
        rotation, position = data.geom_xmat[g].reshape(3, 3), data.geom_xpos[g]
        if model.geom_type[g] == mujoco.mjtGeom.mjGEOM_MESH:
            mesh = model.geom_dataid[g]
            local = model.mesh_vert[model.mesh_vertadr[mesh] : model.mesh_vertadr[mesh] + model.mesh_vertnum[mesh]]
        else:
            local = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)]) * model.geom_size[g]
        points.append(local @ rotation.T + position)
    return np.vstack(points)


def contact_scene(spec: mujoco.MjSpec, pose: dict[str, float]) -> tuple[mujoco.MjModel, mujoco.MjData]:
    """The model in ``pose`` with a table whose top sits 2 mm inside the index fingertip."""
    model = spec.compile()
    data = mujoco.MjData(model)
    qpos = data.qpos.copy()
    for name, value in pose.items():
        joint = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, name)
        if joint >= 0:
            qpos[model.jnt_qposadr[joint]] = value
    data.qpos[:] = qpos
    mujoco.mj_forward(model, data)
    points = tip_points(model, data, model.body("right_hand_t").id)
    lowest = points[np.argmin(points[:, 2])]
    table = spec.worldbody.add_geom()
    table.name = "bench_table"
    table.type = mujoco.mjtGeom.mjGEOM_BOX
    table.size = [0.1, 0.1, 0.01]
    table.pos = [lowest[0], lowest[1], lowest[2] + 0.002 - 0.01]
    table.contype, table.conaffinity = 1, 1  # collide with either model's bitmasks
    for geom in spec.geoms:
        if geom.name == "floor":  # the thesis file's own floor: the test pose reaches below it
            geom.contype, geom.conaffinity = 0, 0
    model = spec.compile()
    data = mujoco.MjData(model)
    data.qpos[:] = qpos
    for a in range(model.nu):
        data.ctrl[a] = qpos[model.jnt_qposadr[model.actuator_trnid[a, 0]]]
    return model, data


def realtime_factor(model: mujoco.MjModel, data: mujoco.MjData) -> tuple[float, int, int]:
    for _ in range(SETTLE_STEPS):
        mujoco.mj_step(model, data)
    steps = round(TIMED_SECONDS / model.opt.timestep)
    start = time.perf_counter()
    for _ in range(steps):
        mujoco.mj_step(model, data)
    wall = time.perf_counter() - start
    table = model.geom("bench_table").id
    touching = sum(1 for c in data.contact[: data.ncon] if table in (c.geom1, c.geom2))
    warnings = sum(w.number for w in data.warning)
    return steps * model.opt.timestep / wall, touching, warnings


def peer_spec(directory: Path) -> mujoco.MjSpec:
    sys.path.insert(0, str(PEERS))
    from peers import PEERS as FILES
    from peers import xml_text

    text = xml_text("seed_svh_ur5_mujoco").replace(
        'meshdir="meshes"', f'meshdir="{FILES["seed_svh_ur5_mujoco"].parent / "meshes"}"'
    )
    path = directory / "thesis.xml"
    path.write_text(text)
    return mujoco.MjSpec.from_file(str(path))


NOTES = """\
`--check` rebuilds in a temporary folder and takes no hulls from the folder it checks: with an empty hull cache
(the first (c) row) every collision mesh is decomposed again; with the cache filled (the second) it is what a
developer's machine sees ([build.md](/docs/build.md#build---check-trusts-nothing-it-checks)).

Two notes on (d):

- **The thesis model's run differs.** It uses RK4 at 1 ms. Its undamped servos swing its 0.09 kg arm away from
  the pose, so at the end of its run it no longer touches the table.
- **svhdesc's model:** implicitfast at 1 ms, with 1.3 kg of hand and 21 kg of arm, holds the contact.

The model's speed against the thesis' in more scenes, with a step profile:
[model_speed.md](/docs/results/model_speed.md).

## Earlier measurements, not rerun by this script

The same scene with one hull per link instead of the decompositions: `ur5_svh_right` at 33.2x realtime (31
colliding geoms) against 26.4x decomposed (179 colliding geoms), on a 2-core Xeon with AVX-512.

The ratio (d) was 2.2 with the coarser finger decompositions that came before the sliced finger meshes, measured on
another machine where (d) ranged 18 to 22x in one run. On the Xeon most of the drop was the finer finger
decompositions: they doubled the colliding geoms (90 to 179), and MuJoCo's collision detection took 17.7 instead of
13.5 us of a 37.9 instead of 32.9 us step (`mjData.timer`). The model built just before them
(`generated/ur5_svh_right` at commit 5498c62) ran the same scene at 30.1x there, a ratio of 1.90; the rest of the
way to 2.2 was the other machine.
"""


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="skip (c) with an empty hull cache (minutes)")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory(prefix="svhdesc-bench-") as tmp:
        root = Path(tmp)
        out = root / "out"
        cold, cold_counts = timed(["build", "--out", str(out), "--timings"], REPO, root / "cache")
        warm, _ = timed(["build", "--out", str(out)], REPO, root / "cache")
        forced, forced_counts = timed(["build", "--out", str(out), "--force", "--timings"], REPO, root / "cache")
        clone = root / "clone"
        subprocess.run(["git", "clone", "-q", str(REPO), str(clone)], check=True)
        if args.quick:  # the clone's hull cache seeded with the cold build's: (c) as a developer's machine sees it
            shutil.copytree(root / "cache", root / "clone-cache")
            check_cold, cold_check_counts = None, "skipped (--quick)"
        else:
            check_cold, cold_check_counts = timed(["build", "--check", "--timings"], clone, root / "clone-cache")
        check_warm, warm_check_counts = timed(["build", "--check", "--timings"], clone, root / "clone-cache")

        ours = mujoco.MjSpec.from_file(str(REPO / "generated" / VARIANT / f"{VARIANT}.xml"))
        probe = ours.compile()
        test = probe.key("test")
        pose = {probe.joint(j).name: float(test.qpos[probe.jnt_qposadr[j]]) for j in range(probe.njnt)}
        our_rtf, our_contacts, our_warnings = realtime_factor(*contact_scene(ours, pose))
        thesis_rtf, thesis_contacts, thesis_warnings = realtime_factor(*contact_scene(peer_spec(root), pose))

    rows = [
        ("(a) cold build, 3 variants, empty cache", f"{cold:.1f} s", "<= 180 s", cold <= 180, cold_counts),
        ("(b) warm build, unchanged (up-to-date check)", f"{warm:.2f} s", "<= 2 s", warm <= 2, ""),
        ("(b) warm build, --force (full rebuild, cache hits)", f"{forced:.2f} s", "(info)", True, forced_counts),
        (
            "(c) --check on a clean clone, empty hull cache",
            "-" if check_cold is None else f"{check_cold:.1f} s",
            "(info)",
            True,
            cold_check_counts,
        ),
        ("(c) --check again, hull cache filled", f"{check_warm:.2f} s", "(info)", True, warm_check_counts),
        (
            f"(d) {VARIANT} realtime factor, fingertip pressed",
            f"{our_rtf:.2f}x",
            "",
            True,
            f"{our_contacts} tip-table contacts, {our_warnings} warnings",
        ),
        (
            "(d) thesis model, same scene",
            f"{thesis_rtf:.2f}x",
            "",
            True,
            f"{thesis_contacts} tip-table contacts, {thesis_warnings} warnings",
        ),
        (
            "(d) ratio svhdesc / thesis",
            f"{our_rtf / thesis_rtf:.2f}",
            ">= 1.0",
            our_rtf >= thesis_rtf and our_warnings == 0,
            "",
        ),
    ]
    width = max(len(r[0]) for r in rows)
    body = ["| figure | measured | target | detail |", "|---|---|---|---|"]
    for name, value, target, ok, note in rows:
        mark = "" if target in ("", "(info)") else ("  met" if ok else "  MISSED")
        print(f"{name:<{width}}  {value:>9}  {target:>8}{mark}  {note}")
        body.append(f"| {name} | {value} | {target}{mark} | {note} |")
    path = write("build", "Build speed and the model's speed in a contact scene", [*body, "", NOTES.rstrip()])
    print(f"wrote {path.relative_to(REPO)}")


if __name__ == "__main__":
    main()
