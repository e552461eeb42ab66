"""Every driven joint reaches both ends of its range with contacts and gravity on, as on the real robot.

Driven joints are the hand's channels (those of the coupling spec that built the model; an SVH recognised by its
joint names when no configuration is known) and every other joint an actuator drives (an arm's, a leg's: any
robot, whatever its config calls them).

From ``home``, each driven joint alone is commanded to its lower end, then its upper end, then (a channel)
back, the others held where they are; each end must be reached within TOLERANCE of the range, and each coupled
joint must reach its polynomial's image of the channel's ends. A joint that stops short names the body pair in contact
with what it moves (a pair whose bodies both move with it included: two followers of one channel), the
deepest new contact first: the collision geometry that blocks it. A hand channel so blocked fails (the real
hand moves freely); an arm joint whose range crosses its own body is listed with the pair and passes, since
no arm reaches every end from every pose. An arm joint that stops short with nothing in contact where gravity and
its friction need all of its drive's force limit (the source's <limit effort>: Talos lifts its arm sideways only so
far) is listed so too: the source's rating, not the model. Any other stop with nothing in contact fails: its servo
cannot carry the load (too soft for its friction), or is too slow. A stroke may take MAX_TIME plus its length at
MIN_SPEED, or at the drive's own speed where slower (drive_speed).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from svhdesc.model import actuated_joints, couplings
from svhdesc.polynomial import polyval
from svhdesc.validate.handsim import hand_parts
from svhdesc.validate.options import Options
from svhdesc.validate.pair import ModelPair
from svhdesc.validate.report import Check, fmt, not_run, skipped, table, verdict

TOLERANCE = 0.01  # of the channel's range
MAX_TIME = 3.0  # s per stroke (the slowest channel, 1 rad at 1 rad/s, settles in under 2 s) ...
MIN_SPEED = 2.0  # ... plus the stroke's length at this speed (rad/s, m/s; a slower drive's own: drive_speed)
SETTLED_SPEED = 1e-3  # rad/s: a stroke ends early once the channels (an arm joint) are this still near the goal ...
STALLED = 0.2  # s ... or this long short of it
SWEEP_SAMPLES = 41  # positions over a blocked channel's range where its own parts are looked for meeting
EFFORT_BOUND = 0.95  # of a drive's force limit: gravity and friction that large stop an arm joint where the source's
# rating stops it (a note, not a failure)


def subtree(model: Any, body: int) -> set[int]:
    bodies = {body}
    for b in range(body + 1, model.nbody):
        if int(model.body_parentid[b]) in bodies:
            bodies.add(b)
    return bodies


def drive_speed(model: Any, actuator: int) -> float:
    """The speed (rad/s, m/s) a stroke may take: MIN_SPEED, or half what the joint's damping lets its drive reach at
    full effort where that is slower (a motor rated 0.63 rad/s, the Kinova's, as `svhdesc init` damps it; half: gravity
    and friction take their share of the effort)."""
    joint = int(model.actuator_trnid[actuator, 0])
    damping = float(model.dof_damping[model.jnt_dofadr[joint]])
    if damping <= 0 or not model.actuator_forcelimited[actuator]:
        return MIN_SPEED
    effort = float(np.abs(model.actuator_forcerange[actuator]).max() * abs(model.actuator_gear[actuator, 0]))
    return min(MIN_SPEED, 0.5 * effort / damping)


@dataclass(frozen=True)
class Motion:
    """What a stroke moves: the joint's actuator, its qpos address (or several of each, moved at once), the dofs
    that must be still for it to end, and the bodies that move with it; ``pinned`` (qpos addresses, their values,
    dofs) are put back after every step: a floating base held where it rests."""

    actuator: int | np.ndarray
    adr: int | np.ndarray
    dofs: np.ndarray
    bodies: set[int]
    pinned: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None


def stroke(model: Any, data: Any, motion: Motion, goal: Any, tol: Any) -> dict[tuple[str, str], float]:
    """Command ``goal`` and step until the dofs are still: near the goal (reached) or, for STALLED s, short of it
    (blocked, or a servo that cannot carry the load); at most the stroke's time. Returns the body pairs the moving
    bodies touched on the way (sampled as the stillness is), deepest contact each: a joint that scraped past its
    own robot (TIAGo's arm_left_3_link along the torso, 3 s) and ran out of time is short with nothing in contact
    at the end."""
    import mujoco

    actuators, adrs = np.atleast_1d(motion.actuator), np.atleast_1d(motion.adr)
    goals, tols = np.broadcast_to(goal, adrs.shape), np.broadcast_to(tol, adrs.shape)
    duration = MAX_TIME + max(
        abs(g - data.qpos[a]) / drive_speed(model, int(u)) for g, a, u in zip(goals, adrs, actuators)
    )
    data.ctrl[actuators] = goals
    stalled_since, touched = None, {}
    for step in range(int(round(duration / model.opt.timestep))):
        mujoco.mj_step(model, data)
        if motion.pinned is not None:
            data.qpos[motion.pinned[0]], data.qvel[motion.pinned[2]] = motion.pinned[1], 0.0
        if step % 20:
            continue
        for pair, depth in touching(model, data, motion.bodies).items():
            touched[pair] = min(touched.get(pair, 0.0), depth)
        still = bool(np.all(np.abs(data.qvel[motion.dofs]) < SETTLED_SPEED))
        if still and np.all(np.abs(data.qpos[adrs] - goals) < tols / 4):
            break
        stalled_since = (stalled_since if stalled_since is not None else data.time) if still else None
        if stalled_since is not None and data.time - stalled_since >= STALLED:
            break
    return touched


def touching(model: Any, data: Any, moving: set[int]) -> dict[tuple[str, str], float]:
    """Body pairs in contact with at least one body among ``moving`` -> their deepest contact distance."""
    pairs: dict[tuple[str, str], float] = {}
    for contact in data.contact[: data.ncon]:
        b1, b2 = int(model.geom_bodyid[contact.geom1]), int(model.geom_bodyid[contact.geom2])
        if b1 in moving or b2 in moving:
            key = (model.body(b1).name, model.body(b2).name)
            pairs[key] = min(pairs.get(key, 0.0), float(contact.dist))
    return pairs


def blocking(
    model: Any, data: Any, moving: set[int], before: set[tuple[str, str]], touched: dict[tuple[str, str], float]
) -> list[str]:
    """Body pairs in contact with a body moving with the joint, both bodies moving included: those that were
    not touching when the stroke began first, deepest first. None at the end: the new pairs touched on the way
    (``touched``), which slowed the joint until its time ran out."""
    return [
        f"{a}/{b}" + (" (on the way)" if way else "")
        for (a, b), way in blocking_pairs(model, data, moving, before, touched)
    ]


def blocking_pairs(
    model: Any, data: Any, moving: set[int], before: set[tuple[str, str]], touched: dict[tuple[str, str], float]
) -> list[tuple[tuple[str, str], bool]]:
    """``blocking``'s pairs, each with whether it was only touched on the way."""
    pairs = touching(model, data, moving)
    order = sorted(pairs.items(), key=lambda kv: (kv[0] in before, kv[1]))
    if order:
        return [(pair, False) for pair, _ in order]
    crossed = sorted((depth, pair) for pair, depth in touched.items() if pair not in before)
    return [(pair, True) for _, pair in crossed]


def _linkage(
    model: Any, moving: set[int], before: set[tuple[str, str]], touched: dict[tuple[str, str], float]
) -> list[tuple[str, str]]:
    """The new pairs a stroke touched whose bodies both move with the joint, deepest first: parts of one linkage,
    which a URDF draws as a chain whose collision shapes may meet where the real parts pass each other (Talos'
    grippers: inner_double_link and fingertip_3_link)."""
    names = {model.body(b).name for b in moving}
    return [pair for _, pair in sorted((d, p) for p, d in touched.items() if p not in before and set(p) <= names)]


def _sweep(model: Any, home: int, motion: Motion, followers: list[Any], span: tuple[float, float]) -> dict:
    """The body pairs that penetrate anywhere over the joint's range, the joint and its followers placed by their
    polynomials from home (positions and collision only, no dynamics): every part of a linkage that would block it,
    not only the first its stroke met (Talos' grippers meet on two pairs each)."""
    import mujoco

    data = mujoco.MjData(model)
    if home >= 0:
        mujoco.mj_resetDataKeyframe(model, data, home)
    found: dict[tuple[str, str], float] = {}
    for q in np.linspace(span[0], span[1], SWEEP_SAMPLES):
        data.qpos[motion.adr] = q
        for e in followers:
            data.qpos[model.jnt_qposadr[model.joint(e.joint).id]] = float(polyval(e.coeffs, q))
        mujoco.mj_fwdPosition(model, data)
        for pair, depth in touching(model, data, motion.bodies).items():
            if depth < 0:
                found[pair] = min(found.get(pair, 0.0), depth)
    return found


def _exclude_hint(pairs: list[tuple[str, str]]) -> str:
    if not pairs:
        return ""
    listed = ", ".join(f"[{a}, {b}]" for a, b in pairs)
    return f" (parts that move with it: if they pass each other on the real robot, add collision.exclude: [{listed}])"


def _effort_bound(model: Any, data: Any, joint: int, actuator: int) -> str:
    """Why a joint at rest short of its goal is where its drive's force limit leaves it: gravity's torque there (with
    the joint's friction) reaches EFFORT_BOUND of the limit (Talos' arm_left_2_joint, rated 22.32 N m, meets 22.6 N m
    of its arm's weight at 0.96 rad of 2.88): what the source's rating allows, said as such; empty otherwise (a
    servo too soft for its friction, or too slow, is the model's fault)."""
    import mujoco

    dof = int(model.jnt_dofadr[joint])
    effort = float(np.abs(model.actuator_forcerange[actuator]).max() * abs(model.actuator_gear[actuator, 0]))
    if not model.actuator_forcelimited[actuator]:
        effort = np.inf
    if model.jnt_actfrclimited[joint]:
        effort = min(effort, float(np.abs(model.jnt_actfrcrange[joint]).max()))
    load = abs(float(data.qfrc_bias[dof])) + float(model.dof_frictionloss[dof])
    if not np.isfinite(effort) or load < EFFORT_BOUND * effort:
        return ""
    unit = "N" if int(model.jnt_type[joint]) == int(mujoco.mjtJoint.mjJNT_SLIDE) else "N m"
    return f"gravity and friction there ({load:.3g} {unit}) need all of its drive's {effort:.3g} {unit}"


def driven_joints(pair: ModelPair) -> tuple[dict[str, tuple[float, float]], dict[str, tuple[float, float]]]:
    """(the hand's channels, every other joint an actuator drives) -> commanded range, each with a range to cover
    (a continuous joint without one is left out)."""
    channels = hand_parts(pair).channels
    others = {
        n: r for n, r in actuated_joints(pair.model).items() if n not in channels and -math.inf < r[0] < r[1] < math.inf
    }
    return channels, others


def check_range_of_motion(pair: ModelPair, options: Options) -> list[Check]:
    import mujoco

    bound = f"each end within {TOLERANCE:.0%} of the range"
    if pair.model is None:
        return [not_run("range_of_motion", "the MJCF does not compile", bound)]
    model = pair.model
    hand = hand_parts(pair)
    channels, others = driven_joints(pair)
    if not channels and not others:
        return [skipped("range_of_motion", "no driven joint with a range", bound)]
    strokes = _Strokes(
        model,
        mujoco.MjData(model),
        mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_KEY, "home"),
        np.array([model.jnt_dofadr[model.joint(n).id] for n in channels], dtype=int),
        couplings(model),
        {model.joint(int(model.actuator_trnid[a, 0])).name: a for a in range(model.nu)},
        hand.short,
    )
    problems: list[str] = []
    notes: list[str] = []
    by_channel = {name: strokes.joint(name, low, high, problems, None) for name, (low, high) in channels.items()}
    driven = {name: strokes.joint(name, low, high, problems, notes) for name, (low, high) in others.items()}
    results = by_channel | driven
    # An arm joint stopped by its own robot, or by its own rating against gravity, is listed in the notes, not ranked.
    ranked = [n for n in results if not {"own_robot", "effort_bound"} & set(results[n])] or list(results)
    worst = min(ranked, key=lambda n: results[n]["fraction"])
    rows = [
        [
            hand.short(n),
            "channel" if n in channels else "driven",
            f"{r['range'][0]:.4f} .. {r['range'][1]:.4f}",
            f"{r['reached'][0]:.4f} .. {r['reached'][1]:.4f}",
            f"{100 * r['fraction']:.1f} %",
        ]
        for n, r in results.items()
    ]
    summary = f"{len(channels)} channels, {len(others)} other driven joints, contacts and gravity on, from 'home'"
    return [
        Check(
            "range_of_motion",
            verdict(not problems),
            f"worst {fmt(100 * results[worst]['fraction'])} % ({hand.short(worst)})",
            bound,
            "; ".join(problems + notes) or summary,
            {"channels": by_channel, "driven": driven, "tolerance": TOLERANCE, "notes": notes},
            table=table(rows, ["joint", "kind", "range", "reached", "reached"]),
        )
    ]


@dataclass
class _Strokes:
    """Driven joints moved one at a time from ``home`` (the model's reset state without one)."""

    model: Any
    data: Any
    home: int  # keyframe id, < 0 where there is none
    hand_dofs: np.ndarray  # the channels' dofs: a channel's stroke ends once they are still
    equalities: list[Any]  # svhdesc.model.Coupling
    actuator_of: dict[str, int]  # joint -> actuator
    short: Any  # name -> how it is shown

    def joint(self, name: str, low: float, high: float, problems: list[str], notes: list[str] | None) -> dict[str, Any]:
        """Lower end, upper end, lower end again: what the joint and its followers reached (and what blocked
        it); each end missed is appended to `problems`, or to `notes` (where given) when a contact blocks it."""
        import mujoco

        model, data = self.model, self.data
        if self.home >= 0:
            mujoco.mj_resetDataKeyframe(model, data, self.home)
        else:
            mujoco.mj_resetData(model, data)
        mujoco.mj_forward(model, data)
        joint = model.joint(name).id
        adr, actuator = int(model.jnt_qposadr[joint]), self.actuator_of[name]
        dofs = np.array([model.jnt_dofadr[joint]], dtype=int)
        tol = TOLERANCE * (high - low)
        followers = [e for e in self.equalities if e.leader == name]
        moving = set().union(
            subtree(model, int(model.jnt_bodyid[joint])),
            *(subtree(model, int(model.jnt_bodyid[model.joint(e.joint).id])) for e in followers),
        )
        before = set(touching(model, data, moving))
        reached: dict[str, float] = {}
        entry: dict[str, Any] = {"range": [low, high], "followers": {}}
        # A channel goes back down too (the SVH's strokes showed hysteresis); an arm joint's two ends suffice.
        strokes = (
            (("start", low), ("upper", high), ("lower", low)) if notes is None else (("start", low), ("upper", high))
        )
        motion = Motion(actuator, adr, self.hand_dofs if notes is None else dofs, moving)
        swept: dict | None = None
        for label, goal in strokes:
            touched = stroke(model, data, motion, goal, tol)
            q = reached[label] = float(data.qpos[adr])
            if abs(q - goal) > tol:
                blockers = blocking(model, data, moving, before, touched)
                if notes is None and swept is None:  # a channel: every pair of its own parts over its range
                    swept = _sweep(model, self.home, motion, followers, (low, high))
                linkage = _linkage(model, moving, before, {**(swept or {}), **touched})
                miss = Miss(name, label, goal, q, (low, high), tol, blockers, linkage)
                self.judge(miss, joint, actuator, entry, problems, notes)
            for e in followers:
                expected = float(polyval(e.coeffs, goal))
                got = float(data.qpos[model.jnt_qposadr[model.joint(e.joint).id]])
                span = abs(float(polyval(e.coeffs, high)) - float(polyval(e.coeffs, low))) or 1.0
                entry["followers"].setdefault(e.joint, {})[label] = got
                if abs(got - expected) > TOLERANCE * span and abs(q - goal) <= tol:
                    problems.append(f"{e.joint} reaches {got:.3f}, not {expected:.3f}, at {name} {label}")
        lowest = reached.get("lower", reached["start"])
        entry["reached"] = [lowest, reached["upper"]]
        entry["fraction"] = (reached["upper"] - lowest) / (high - low) if high > low else 1.0
        return entry

    def judge(
        self,
        miss: Miss,
        joint: int,
        actuator: int,
        entry: dict[str, Any],
        problems: list[str],
        notes: list[str] | None,
    ) -> None:
        """An end missed: through the limit, stopped where its rating stops it, by a servo too soft, by its own
        robot (an arm joint: a note) or by a contact (a channel: a problem)."""
        name, (low, high), blockers = self.short(miss.joint), miss.range, miss.blockers
        if blockers:
            entry.setdefault("blocked_by", {})[miss.label] = blockers
        text = f"{name} stops at {miss.reached:.3f} of {miss.goal:.4g} going {miss.label}"
        kind, bound = classify(self.model, self.data, miss, joint, actuator)
        if kind == "limit":  # past the end: the limit gave way to the servo
            problems.append(f"{name} goes through its limit to {miss.reached:.3f} (range {low:.4g} .. {high:.4g})")
        elif kind == "rating" and notes is not None:
            entry.setdefault("effort_bound", {})[miss.label] = bound
            notes.append(text + f", nothing in contact: {bound}, its rating stops it there (not a failure)")
        elif not blockers:
            problems.append(
                text + ", nothing in contact and its drive below its force limit: its servo is too soft "
                "(for its friction) or too slow"
            )
        elif notes is not None:
            entry["own_robot"] = True
            notes.append(text + f", its range crosses its own robot: {blockers[0]} (not a failure)")
        else:
            problems.append(text + f", blocked by {blockers[0]}" + _exclude_hint(miss.linkage))


def classify(model: Any, data: Any, miss: Miss, joint: int, actuator: int) -> tuple[str, str]:
    """Why a stroke ended short, the pose it ended in being ``data``'s: 'limit' (past an end: the limit gave way to
    the servo), 'contact' (something touches what moves with it: ``miss.blockers``), 'rating' (nothing in contact,
    gravity and friction need all of its drive's force limit: the second item says so) or 'soft' (nothing in
    contact, its drive below its force limit: the servo is too soft for its friction, or too slow)."""
    low, high = miss.range
    if not low - miss.tol <= miss.reached <= high + miss.tol:
        return "limit", ""
    if miss.blockers:
        return "contact", ""
    bound = _effort_bound(model, data, joint, actuator)
    return ("rating", bound) if bound else ("soft", "")


@dataclass(frozen=True)
class Miss:
    """A stroke that ended more than ``tol`` from its goal."""

    joint: str
    label: str  # start, upper, lower
    goal: float
    reached: float
    range: tuple[float, float]
    tol: float
    blockers: list[str]  # body pairs in contact, deepest new first
    linkage: list[tuple[str, str]]  # the new pairs touched whose bodies both move with the joint
