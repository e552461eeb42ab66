"""The shipped ur5_svh_right against the thesis' model (../shared/peers seed_svh_ur5_mujoco), in one run.

    python benchmarks/model_vs_thesis.py

(1) Ratio at the `test` keyframe: both models in the same scene (bench.py's: the index fingertip pressed
    2 mm into a table), realtime factor at each model's own timestep, median of 3 alternating trials, each
    from the same settled state (the thesis model's undamped servos swing its arm off the table as it runs,
    so a trial that went on from the previous one would time a different, cheaper scene).
    Goal (issue 25): >= 2.0x.
(2) Contact-rich figures of the shipped model: at rest (the table scene above), holding the `power` grasp
    (closed on its cylinder as `svhdesc validate`'s grasps check does), and all fingers moving (every hand
    channel on its own sine across its range, no object).
(3) Where a step's time goes in each: MjData.timer (collision broadphase, narrowphase = mid- and
    narrowphase, constraint solve, the rest), per step.
(4) Candidate cuts, measured in memory on the `test` scene and not shipped: the SRDF's `Never` pairs (the
    collision matrix: never within 1 cm over 5000 random poses) excluded from contact, as contype/conaffinity
    bits would; hulls capped at 32 vertices; noslip_iterations 2 or 0; looser solver and collision (ccd)
    tolerances; a 2 ms timestep (realtime factors count simulated time, so a longer step counts in full); and, as a
    ceiling rather than a candidate, no self-collision at all (what the best cut of self-collision cost could
    buy). Each against the shipped model, alternating, median of 3; a cut that changes geometry or the solver
    would still have to pass collision_fidelity, grasps and range_of_motion before it ships.
Writes docs/results/model_speed.md. Not a test: machines are noisy; the ratio is measured in one run.
"""

from __future__ import annotations

import math
import statistics
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

import mujoco
import numpy as np
import yaml

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))
sys.path.insert(0, str(REPO / "benchmarks"))

from bench import contact_scene, peer_spec  # noqa: E402
from results import write  # noqa: E402

from svhdesc.model import get  # noqa: E402
from svhdesc.validate import grasps  # noqa: E402
from svhdesc.validate.handsim import find_hand  # noqa: E402

VARIANT = "ur5_svh_right"
MJCF = REPO / "generated" / VARIANT / f"{VARIANT}.xml"
HAND = get(VARIANT).hand
SETTLE_STEPS = 500
TIMED_SECONDS = 10.0  # simulated seconds per trial, each from the same settled state
TRIALS = 3
GOAL = 2.0
T = mujoco.mjtTimer
PHASES = (
    ("broadphase", T.mjTIMER_COL_BROAD),
    ("narrowphase", T.mjTIMER_COL_NARROW),
    ("constraint", T.mjTIMER_CONSTRAINT),
)


def run(model: mujoco.MjModel, data: mujoco.MjData, steps: int, drive=None) -> float:
    """Seconds of wall time for ``steps`` mj_steps (``drive(data)`` before each, when given)."""
    start = time.perf_counter()
    for _ in range(steps):
        if drive is not None:
            drive(data)
        mujoco.mj_step(model, data)
    return time.perf_counter() - start


def rtf(model: mujoco.MjModel, data: mujoco.MjData, drive=None) -> float:
    steps = round(TIMED_SECONDS / model.opt.timestep)
    return steps * model.opt.timestep / run(model, data, steps, drive)


def settled(model: mujoco.MjModel, data: mujoco.MjData) -> np.ndarray:
    """The scene's full state after SETTLE_STEPS: every trial starts from it."""
    run(model, data, SETTLE_STEPS)
    state = np.empty(mujoco.mj_stateSize(model, mujoco.mjtState.mjSTATE_FULLPHYSICS))
    mujoco.mj_getState(model, data, state, mujoco.mjtState.mjSTATE_FULLPHYSICS)
    return state


def trial(model: mujoco.MjModel, data: mujoco.MjData, start: np.ndarray) -> float:
    """Realtime factor over TIMED_SECONDS from ``start`` (the same stretch of simulated time in every trial)."""
    mujoco.mj_setState(model, data, start, mujoco.mjtState.mjSTATE_FULLPHYSICS)
    return rtf(model, data)


def profile(model: mujoco.MjModel, data: mujoco.MjData, drive=None) -> dict[str, float]:
    """Microseconds per step: the whole step and its phases (MjData.timer), mean contacts and constraints."""
    run(model, data, SETTLE_STEPS, drive)
    for timer in data.timer:
        timer.duration, timer.number = 0.0, 0
    steps = round(TIMED_SECONDS / model.opt.timestep)
    ncon = nefc = 0
    start = time.perf_counter()
    for _ in range(steps):
        if drive is not None:
            drive(data)
        mujoco.mj_step(model, data)
        ncon, nefc = ncon + data.ncon, nefc + data.nefc
    wall = time.perf_counter() - start
    per = {name: 1e6 * data.timer[phase].duration / steps for name, phase in PHASES}
    per["step"] = 1e6 * data.timer[T.mjTIMER_STEP].duration / steps
    per["wall"] = 1e6 * wall / steps
    per["rtf"] = model.opt.timestep * steps / wall
    per["ncon"], per["nefc"] = ncon / steps, nefc / steps
    return per


def test_pose(spec: mujoco.MjSpec) -> dict[str, float]:
    probe = spec.compile()
    key = probe.key("test")
    return {probe.joint(j).name: float(key.qpos[probe.jnt_qposadr[j]]) for j in range(probe.njnt)}


def power_grasp() -> tuple[mujoco.MjModel, mujoco.MjData]:
    """The shipped model holding the `power` grasp's cylinder, closed as the grasps check closes it."""
    grasp = dict(yaml.safe_load((REPO / "config" / "svhdesc.yaml").read_text())["grasps"]["power"])
    base = mujoco.MjModel.from_xml_path(str(MJCF))
    hand = find_hand(base, HAND)
    placement, _ = grasps._placement(base, hand, grasp)
    sim = grasps._GraspSim.welded(grasps._scene(MJCF, grasp, placement, f"{hand.prefix}_base_link"), hand)
    sim.close(grasps._key_targets(sim.model, hand, "power"))
    sim.release()
    return sim.model, sim.data


def fingers_moving() -> tuple[mujoco.MjModel, mujoco.MjData, object]:
    """The shipped model at `test`, every hand channel on its own sine (periods 0.7-1.5 s) across its range."""
    model = mujoco.MjModel.from_xml_path(str(MJCF))
    data = mujoco.MjData(model)
    mujoco.mj_resetDataKeyframe(model, data, model.key("test").id)
    hand = find_hand(model, HAND)
    channels = np.array(sorted(hand.actuators.values()))
    low, high = model.actuator_ctrlrange[channels].T
    periods = np.linspace(0.7, 1.5, len(channels))
    data.ctrl[:] = data.qpos[model.jnt_qposadr[model.actuator_trnid[:, 0]]]

    def drive(d: mujoco.MjData) -> None:
        phase = 0.5 - 0.5 * np.cos(2 * np.pi * d.time / periods)
        d.ctrl[channels] = low + (high - low) * phase

    return model, data, drive


def never_pairs() -> list[tuple[str, str]]:
    """The link pairs the SRDF's collision matrix disables as ``Never`` touching."""
    from lxml import etree

    srdf = REPO / "generated" / VARIANT / "config" / f"{VARIANT}.srdf"
    return [
        (e.get("link1"), e.get("link2"))
        for e in etree.parse(str(srdf)).iterfind("disable_collisions")
        if e.get("reason") == "Never"
    ]


def exclude_never(spec: mujoco.MjSpec) -> None:
    bodies = {body.name for body in spec.bodies}
    for first, second in never_pairs():
        if first in bodies and second in bodies:
            exclude = spec.add_exclude()
            exclude.bodyname1, exclude.bodyname2 = first, second


def cap_hulls(spec: mujoco.MjSpec) -> None:
    for mesh in spec.meshes:
        mesh.maxhullvert = 32


def fewer_noslip(spec: mujoco.MjSpec) -> None:
    spec.option.noslip_iterations = 2


def step_2ms(spec: mujoco.MjSpec) -> None:
    """MuJoCo's default timestep. MuJoCo itself then softens the couplings' solref 0.002 s to 0.004 s (a time
    constant below two steps is raised to two)."""
    spec.option.timestep = 0.002


def solver(**settings: float) -> Callable[[mujoco.MjSpec], None]:
    """Solver settings: convergence tolerances and iterations (collision geometry unchanged)."""

    def change(spec: mujoco.MjSpec) -> None:
        for name, value in settings.items():
            setattr(spec.option, name, value)

    return change


def no_self_collision(spec: mujoco.MjSpec) -> None:
    """A ceiling, not a candidate: every robot geom collides with the table only, so no pair of the robot's own
    links is ever tested. What the best possible cut of self-collision cost could buy."""
    for geom in spec.geoms:
        if geom.name != "bench_table" and (geom.contype or geom.conaffinity):
            geom.contype, geom.conaffinity = 2, 1  # the table (1, 1) still meets them


CANDIDATES = {
    "`Never` pairs excluded (collision matrix)": exclude_never,
    "hulls capped at 32 vertices": cap_hulls,
    "noslip_iterations 2 (shipped: 5)": fewer_noslip,
    "noslip_iterations 0": solver(noslip_iterations=0),
    "solver tolerance 1e-6 (shipped: 1e-8)": solver(tolerance=1e-6),
    "ccd_tolerance 1e-4 (shipped: 1e-6)": solver(ccd_tolerance=1e-4),
    "both tolerances, noslip_iterations 0": solver(tolerance=1e-6, ccd_tolerance=1e-4, noslip_iterations=0),
    "timestep 2 ms (shipped: 1 ms)": step_2ms,
    "ceiling: no self-collision at all (not shippable)": no_self_collision,
}


def narrowphase_pairs(model: mujoco.MjModel, data: mujoco.MjData, steps: int = 100) -> dict[tuple[str, str], float]:
    """Geom pairs per step that pass the broad- and midphase, by body pair (MuJoCo's contact filter callback sees
    each of them; it applies the contype/conaffinity test it replaces)."""
    counts: dict[tuple[str, str], int] = {}

    def count(m: mujoco.MjModel, _: mujoco.MjData, g1: int, g2: int) -> int:
        if not (m.geom_contype[g1] & m.geom_conaffinity[g2] or m.geom_contype[g2] & m.geom_conaffinity[g1]):
            return 1
        first, second = sorted(m.body(m.geom_bodyid[g]).name for g in (g1, g2))
        counts[first, second] = counts.get((first, second), 0) + 1
        return 0

    mujoco.set_mjcb_contactfilter(count)
    try:
        for _ in range(steps):
            mujoco.mj_step(model, data)
    finally:
        mujoco.set_mjcb_contactfilter(None)
    return {pair: n / steps for pair, n in sorted(counts.items(), key=lambda item: -item[1])}


def closest_approach(model: mujoco.MjModel, pairs: list[tuple[str, str]], samples: int = 2000) -> list[float]:
    """Each body pair's smallest signed distance (m, at most 0.05; negative: the hulls overlap) over random hand
    poses: every hand joint anywhere in its range, at one of its limits 30 % of the time (coupled joints drawn
    freely too, so the poses are a superset of the reachable ones)."""
    data, rng = mujoco.MjData(model), np.random.default_rng(0)
    hand = [j for j in range(model.njnt) if HAND.owns(model.joint(j).name)]
    collides = (model.geom_contype | model.geom_conaffinity) > 0
    geoms = {
        name: [g for g in range(model.ngeom) if collides[g] and model.geom_bodyid[g] == model.body(name).id]
        for pair in pairs
        for name in pair
    }
    closest, fromto = [math.inf] * len(pairs), np.zeros(6)
    for _ in range(samples):
        data.qpos[:] = model.qpos0
        for j in hand:
            low, high = model.jnt_range[j]
            draw = rng.random()
            data.qpos[model.jnt_qposadr[j]] = low if draw < 0.15 else high if draw < 0.3 else rng.uniform(low, high)
        mujoco.mj_kinematics(model, data)
        for k, (first, second) in enumerate(pairs):
            for g1 in geoms[first]:
                for g2 in geoms[second]:
                    closest[k] = min(closest[k], mujoco.mj_geomDistance(model, data, g1, g2, 0.05, fromto))
    return closest


def narrowphase_rows(scene: tuple[mujoco.MjModel, mujoco.MjData], start: np.ndarray) -> list[str]:
    mujoco.mj_setState(scene[0], scene[1], start, mujoco.mjtState.mjSTATE_FULLPHYSICS)
    pairs = narrowphase_pairs(*scene)
    own = [pair for pair in pairs if "world" not in pair]
    approach = dict(zip(own, closest_approach(scene[0], own)))
    return [
        f"| `{a}`, `{b}` | {n:.1f} | "
        + (f"{1e3 * approach[a, b]:.1f}" if (a, b) in approach else "- (the table)")
        + " |"
        for (a, b), n in pairs.items()
    ]


def candidates(pose: dict[str, float], shipped: tuple[mujoco.MjModel, mujoco.MjData]) -> list[str]:
    """Table rows: each candidate's realtime factor over the shipped model's at `test`, median of 3."""
    rows = []
    for name, change in CANDIDATES.items():
        spec = mujoco.MjSpec.from_file(str(MJCF))
        change(spec)
        scene = contact_scene(spec, pose)
        start, shipped_start = settled(*scene), settled(*shipped)
        ratios = [trial(*scene, start) / trial(*shipped, shipped_start) for _ in range(TRIALS)]
        rows.append(f"| {name} | {statistics.median(ratios):.2f} | {scene[1].ncon} |")
    return rows


def main() -> None:
    with tempfile.TemporaryDirectory(prefix="svhdesc-mvt-") as tmp:
        ours_spec = mujoco.MjSpec.from_file(str(MJCF))
        pose = test_pose(ours_spec)
        ours = contact_scene(ours_spec, pose)
        thesis = contact_scene(peer_spec(Path(tmp)), pose)
    starts = [settled(*ours), settled(*thesis)]
    trials = [(trial(*ours, starts[0]), trial(*thesis, starts[1])) for _ in range(TRIALS)]
    for (model, data), start in zip((ours, thesis), starts):  # the profile below starts there too
        mujoco.mj_setState(model, data, start, mujoco.mjtState.mjSTATE_FULLPHYSICS)
    ratios = [a / b for a, b in trials]
    ratio = statistics.median(ratios)
    moving = fingers_moving()
    scenes = {
        "rest (test pose, tip on table)": profile(*ours),
        "power grasp held": profile(*power_grasp()),
        "all fingers moving": profile(*moving),
        "thesis model, rest (same table)": profile(*thesis),
    }
    body = [
        "Absolute figures depend on the machine and its load (the header gives both); the ratio is measured in",
        "one run, alternating the two models, each trial timing the same stretch of simulated time from the same",
        "settled state, which is robust to load.",
        "",
        f"## ur5_svh_right / thesis model at `test`, median of {TRIALS}",
        "",
        "| trial | ur5_svh_right RTF | thesis RTF | ratio |",
        "|---|---|---|---|",
        *[f"| {i + 1} | {a:.2f}x | {b:.2f}x | {a / b:.2f} |" for i, (a, b) in enumerate(trials)],
        f"| **median** | | | **{ratio:.2f}** (goal >= {GOAL}: {'met' if ratio >= GOAL else 'NOT met'}) |",
        "",
        "## Contact-rich figures and where a step's time goes (MjData.timer, microseconds per step)",
        "",
        "| scene | RTF | step | broadphase | narrowphase | constraint | other | contacts | constraint rows |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for name, p in scenes.items():
        other = p["step"] - p["broadphase"] - p["narrowphase"] - p["constraint"]
        body.append(
            f"| {name} | {p['rtf']:.2f}x | {p['step']:.1f} | {p['broadphase']:.1f} | {p['narrowphase']:.1f} "
            f"| {p['constraint']:.1f} | {other:.1f} | {p['ncon']:.1f} | {p['nefc']:.0f} |"
        )
    body += [
        "",
        "## Candidate cuts, measured in memory (not shipped)",
        "",
        "Realtime factor over the shipped model's at `test`, median of 3 alternating trials (1.00: no gain).",
        "",
        "| candidate | speed-up | contacts at the end |",
        "|---|---|---|",
        *candidates(pose, ours),
        "",
        "## What reaches the narrowphase at `test`",
        "",
        "Geom pairs per step that pass the broad- and midphase (MuJoCo's contact filter callback, 100 steps from",
        "the settled state), by body pair, and each pair's closest approach over 2000 random hand poses",
        "(`mj_geomDistance`; every hand joint anywhere in its range, at a limit 30 % of the time; negative: the",
        "hulls overlap, so the pair can touch and excluding it would change what collides).",
        "",
        "| body pair | geom pairs per step | closest approach (mm) |",
        "|---|---|---|",
        *narrowphase_rows(ours, starts[0]),
    ]
    path = write("model_speed", "Model speed: ur5_svh_right against the thesis' model", body)
    print("\n".join(body))
    print(f"wrote {path.relative_to(REPO)}")


if __name__ == "__main__":
    main()
