"""range_of_motion on a robot file as it stands (the full tier of `svhdesc validate PATH`).

Every joint a position servo drives (a limited hinge or slide that no coupling makes a follower) goes from the rest
pose (the keyframe the settings name, else keyframe 0, else qpos0 within the limits) toward each end of its range,
its servo aimed at the end of its own ctrlrange (which may pass the joint's limit: the limit must hold), contacts
and gravity on, a floating base held where it rests. All joints go at once, to their upper ends and then to their
lower ends: a 20-joint hand costs two strokes, not forty. A joint that misses an end of its range (within its
ctrlrange) by more than 1 % of it (or its settings' tolerance) goes again alone, the others held at rest, and only
a miss then is judged, with the built variants' rules (range_of_motion.classify); a model that diverges while one
joint is driven alone is one finding, and the check ends there:

- it goes through its limit by more than LIMIT_GIVE of its range: a finding (a limit too soft for the servo, the
  load or a contact on it), except where a contact pushes a URDF's joint through (its meshes collide as MuJoCo's
  convex hulls of them: a note); less is a note (MuJoCo's limits are soft);
- it meets a finger of the same palm (two chains of links branching from a link that is not the robot's base), or
  two parts it moves (the followers of its <mimic>) meet: the gripper closes, which is how a gripper closes: a note
  with the closing position, not a finding;
- anything else stops it: a note with the position, the end and what stops it, as the built variants' arm joints
  get: its own robot (no arm reaches every end from every pose; a URDF's meshes collide as MuJoCo's convex hulls of
  them), the scene (a floor, an object), a contact pushing it past its limit, gravity and friction at its drive's
  force limit (gravity_hold judges ratings), or a servo too soft for its load, friction or a tendon coupling it.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from svhdesc.validate.compile_file import Compiled
from svhdesc.validate.findings import CheckResult, Finding
from svhdesc.validate.poses import is_position_servo, rest_state
from svhdesc.validate.range_of_motion import (
    TOLERANCE,
    Miss,
    Motion,
    blocking_pairs,
    classify,
    stroke,
    subtree,
    touching,
)

CHECK = "range_of_motion"
SHOWN_NOTES = 4  # notes the figure lists; the rest are counted
# MuJoCo's limits are soft: a joint held at its limit under a load sinks past it (the SVH's fingers 0.02 rad of 1.3
# under the hand's weight, TIAGo's suspension 0.28 mm of 5 mm). Through the limit by more than this share of the
# range is a limit that does not hold (a servo range past it: 17 %; fingers starting inside a palm: 22 %).
LIMIT_GIVE = 0.1


@dataclass(frozen=True)
class _Leader:
    name: str
    joint: int
    actuator: int
    low: float
    high: float
    tol: float
    command: tuple[float, float]  # the servo's ctrlrange
    roots: frozenset[int]  # the bodies its joint and its followers' joints move
    bodies: frozenset[int]  # everything that moves with it


def _followers(model: Any) -> dict[int, set[int]]:
    """Leader joint -> the joints an active joint equality makes follow it."""
    import mujoco

    out: dict[int, set[int]] = {}
    for e in np.flatnonzero(model.eq_type == mujoco.mjtEq.mjEQ_JOINT):
        if model.eq_obj2id[e] >= 0:
            out.setdefault(int(model.eq_obj2id[e]), set()).add(int(model.eq_obj1id[e]))
    return out


def _leaders(model: Any, tolerances: Mapping[str, float], left_out: Mapping[str, str]) -> list[_Leader]:
    followers = _followers(model)
    following = set().union(*followers.values()) if followers else set()
    leaders: dict[int, _Leader] = {}
    for i in range(model.nu):
        joint = int(model.actuator_trnid[i, 0])
        if not (is_position_servo(model, i) and model.actuator_ctrllimited[i]) or joint in leaders:
            continue
        if model.jnt_type[joint] not in (2, 3) or not model.jnt_limited[joint] or joint in following:
            continue
        name = model.joint(joint).name or str(joint)
        low = max(float(model.actuator_ctrlrange[i, 0]), float(model.jnt_range[joint, 0]))
        high = min(float(model.actuator_ctrlrange[i, 1]), float(model.jnt_range[joint, 1]))
        if high <= low or name in left_out:
            continue
        roots = frozenset(int(model.jnt_bodyid[j]) for j in {joint, *followers.get(joint, ())})
        bodies = frozenset(set().union(*(subtree(model, r) for r in roots)))
        tol = tolerances.get(name, TOLERANCE * (high - low))
        command = (float(model.actuator_ctrlrange[i, 0]), float(model.actuator_ctrlrange[i, 1]))
        leaders[joint] = _Leader(name, joint, i, low, high, tol, command, roots, bodies)
    return list(leaders.values())


def _pinned(model: Any, data: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
    """A floating base's coordinates, held where they rest while the joints move."""
    free = np.flatnonzero(model.jnt_type == 0)
    if not free.size:
        return None
    adrs = np.concatenate([np.arange(model.jnt_qposadr[j], model.jnt_qposadr[j] + 7) for j in free])
    dofs = np.concatenate([np.arange(model.jnt_dofadr[j], model.jnt_dofadr[j] + 6) for j in free])
    return adrs, data.qpos[adrs].copy(), dofs


@dataclass
class _Run:
    compiled: Compiled
    rest: Any  # MjData at the rest pose
    label: str  # how findings name the rest pose
    data: Any
    pinned: tuple[np.ndarray, np.ndarray, np.ndarray] | None

    def reset(self) -> None:
        import mujoco

        mujoco.mj_copyData(self.data, self.compiled.model, self.rest)
        mujoco.mj_forward(self.compiled.model, self.data)

    def diverged(self) -> bool:
        """Whether the last stroke went non-finite (MuJoCo resets the state then, warning BADQACC)."""
        import mujoco

        return self.data.warning[mujoco.mjtWarning.mjWARN_BADQACC].number > 0 or not np.all(np.isfinite(self.data.qpos))

    def together(self, leaders: list[_Leader], end: str) -> list[bool]:
        """Every leader to its ``end`` at once: whether each got there."""
        model = self.compiled.model
        self.reset()
        adrs = np.array([model.jnt_qposadr[x.joint] for x in leaders])
        motion = Motion(
            np.array([x.actuator for x in leaders]),
            adrs,
            np.array([model.jnt_dofadr[x.joint] for x in leaders]),
            set().union(*(x.bodies for x in leaders)),
            self.pinned,
        )
        commands = np.array([_command(x, end) for x in leaders])
        stroke(model, self.data, motion, commands, np.array([x.tol for x in leaders]))
        return [abs(q - _goal(x, end)) <= x.tol for x, q in zip(leaders, self.data.qpos[adrs])]

    def alone(self, leader: _Leader, end: str) -> tuple[Miss, list[tuple[tuple[str, str], bool]]] | None:
        """The leader alone to its ``end``, the others held at rest: None if it gets there, else the miss."""
        model, data = self.compiled.model, self.data
        self.reset()
        moving = set(leader.bodies)
        before = set(touching(model, data, moving))
        adr, dof = int(model.jnt_qposadr[leader.joint]), int(model.jnt_dofadr[leader.joint])
        motion = Motion(leader.actuator, adr, np.array([dof]), moving, self.pinned)
        touched = stroke(model, data, motion, _command(leader, end), leader.tol)
        reached, goal = float(data.qpos[adr]), _goal(leader, end)
        if abs(reached - goal) <= leader.tol:
            return None
        pairs = blocking_pairs(model, data, moving, before, touched)
        blockers = [f"{a}/{b}" + (" (on the way)" if way else "") for (a, b), way in pairs]
        range_ = (leader.low, leader.high)
        return Miss(leader.name, end, goal, reached, range_, leader.tol, blockers, []), pairs


def _command(leader: _Leader, end: str) -> float:
    """The servo's target: the end of its own ctrlrange, which may pass the joint's limit (actuator_ranges says so):
    the servo then pushes on the limit, which must hold."""
    return leader.command[1] if end == "upper" else leader.command[0]


def _goal(leader: _Leader, end: str) -> float:
    return leader.high if end == "upper" else leader.low


def _ancestors(model: Any, body: int) -> list[int]:
    chain = [body]
    while chain[-1] != 0:
        chain.append(int(model.body_parentid[chain[-1]]))
    return chain


def _contact_kind(model: Any, leader: _Leader, pair: tuple[str, str]) -> str:
    """'closing' (two parts the leader moves meet, on two branches: its <mimic> followers; or two fingers of one palm:
    two chains of links without a branch, from a link the leader's joint hangs from that is not a floating base,
    which legs hang from), 'scene' (the world's geometry or another body tree) or 'robot'."""
    ids = {model.body(b).name: b for b in range(model.nbody)}
    if any(not name or name not in ids for name in pair):  # an unnamed body: which one is not known
        return "robot"
    first, second = (_ancestors(model, ids[name]) for name in pair)
    if 0 in (first[0], second[0]) or first[-2] != second[-2]:
        return "scene"
    common = next(b for b in first if b in second)
    if common in (first[0], second[0]):
        return "robot"
    if {first[0], second[0]} <= leader.bodies:  # two parts of one linkage, both moved by the leader
        return "closing"
    # The base is a palm where it is fixed (a gripper on its own); a floating base is a trunk whose legs meet.
    trunk = {first[-2]} if model.body_jntnum[first[-2]] else set()
    palms = {int(model.body_parentid[r]) for r in leader.roots} - trunk
    children = np.bincount(model.body_parentid[1:], minlength=model.nbody)
    tops = (chain[chain.index(common) - 1] for chain in (first, second))
    fingers = common in palms and all(all(children[b] <= 1 for b in subtree(model, top)) for top in tops)
    return "closing" if fingers else "robot"


def _judge(run: _Run, leader: _Leader, miss: Miss, pairs: list) -> tuple[Finding | None, str]:
    """A finding, or a note, for a joint that missed an end alone."""
    model = run.compiled.model
    kind, bound = classify(model, run.data, miss, leader.joint, leader.actuator)
    unit = "m" if model.jnt_type[leader.joint] == 2 else "rad"
    at = f"'{leader.name}' stops at {miss.reached:.4g} {unit} of {miss.goal:.4g} going {miss.label}"
    past = max(leader.low - miss.reached, miss.reached - leader.high)
    if kind == "limit" and past <= LIMIT_GIVE * (leader.high - leader.low):
        return (
            None,
            f"'{leader.name}' sinks {past:.3g} {unit} past its {miss.label} limit under its load (a soft limit)",
        )
    if kind == "limit" and not (pairs and run.compiled.kind == "urdf"):
        file, line = run.compiled.where("joint", leader.name)
        going = f"driven to its {miss.label} end {miss.goal:.4g} {unit} from {run.label}"
        touching = f", touching {miss.blockers[0]}" if pairs else ", nothing in contact"
        message = f"joint '{leader.name}' goes through its limit to {miss.reached:.4g} {unit}, {going}{touching}"
        return Finding(CHECK, file, line, message), ""
    if kind == "limit":
        past = f"'{leader.name}' pushed past its {miss.label} limit to {miss.reached:.4g} {unit}"
        return None, f"{past} by contact ({miss.blockers[0]})"
    if kind == "rating":
        return None, f"{at}: {bound} (see gravity_hold)"
    if kind == "soft":
        return None, f"{at}, nothing in contact: its servo is too soft for its load, friction or coupling"
    where = _contact_kind(model, leader, pairs[0][0])
    if where == "closing":
        return None, f"'{leader.name}' closes at {miss.reached:.4g} {unit}: fingers touch ({miss.blockers[0]})"
    what = "the scene" if where == "scene" else "its range crosses its own robot"
    hulls = " (meshes as their convex hulls)" if where == "robot" and run.compiled.kind == "urdf" else ""
    return None, f"{at}: {what}: {miss.blockers[0]}{hulls}"


def _diverges(compiled: Compiled, leader: _Leader, end: str, label: str) -> CheckResult:
    """One finding for a model that diverges while a servo drives its joint: each stroke would diverge again."""
    file, line = compiled.where("joint", leader.name)
    message = f"the model diverges while joint '{leader.name}' is driven to its {end} end from {label}"
    return CheckResult(CHECK, "fail", [Finding(CHECK, file, line, f"{message} (see model_test, settle)")])


def range_of_motion(
    compiled: Compiled, tolerances: Mapping[str, float] | None = None, left_out: Mapping[str, str] | None = None
) -> CheckResult:
    """``tolerances``: joint -> the miss allowed (rad or m); ``left_out``: joint -> why the settings leave it out."""
    import mujoco

    model = compiled.model
    left_out = left_out or {}
    leaders = _leaders(model, tolerances or {}, left_out)
    if not leaders:
        return CheckResult(CHECK, "skipped", reason="no position servo drives a joint with a range")
    rest, label = rest_state(model, compiled.key)
    mujoco.mj_forward(model, rest)
    run = _Run(compiled, rest, label, mujoco.MjData(model), _pinned(model, rest))
    findings, notes, alone = [], [f"'{j}' left out: {why}" for j, why in left_out.items()], 0
    for end in ("upper", "lower"):
        # Moving everything at once may make a model diverge that each joint alone does not (anymal-kinova's
        # hulls): then every joint goes alone, and the first that diverges alone ends the check with one finding.
        reached = run.together(leaders, end)
        reached = [False] * len(leaders) if run.diverged() else reached
        for leader in (x for x, got in zip(leaders, reached) if not got):
            alone += 1
            missed = run.alone(leader, end)
            if run.diverged():
                return _diverges(compiled, leader, end, label)
            if missed is not None:
                finding, note = _judge(run, leader, *missed)
                findings += [finding] if finding else []
                notes += [note] if note else []
    figure = f"{len(leaders)} joint(s) driven to both ends at once from {label}, {alone} end(s) again alone"
    if notes:
        more = f" (+{len(notes) - SHOWN_NOTES})" if len(notes) > SHOWN_NOTES else ""
        figure += "; " + "; ".join(notes[:SHOWN_NOTES]) + more
    return CheckResult(CHECK, "fail" if findings else "pass", findings, figure=figure)
