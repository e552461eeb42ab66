"""Check grasps: the hand closes each configured grasp on its object and holds it as gravity turns.

Each grasp is a keyframe (its channel targets) plus an object (config ``grasps``). The object is
placed in the hand frame and welded there (to the hand's base, which an arm may let give) while the
hand closes from open with gravity off (thumb opposition and spread first); then the weld lets go,
the object settles between the fingers (still
no gravity), and gravity pulls, HOLD seconds along each of three hand directions in turn. Slip is how
far the object moves in the hand frame from where it settled. A grasp that names ``tips`` also
closes on nothing: those fingertips must meet (under TIP_GAP apart) with no other contact on their
fingers (the precision pinch).
"""

from __future__ import annotations

import tempfile
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from svhdesc.errors import SvhdescError
from svhdesc.model import HandId, Model
from svhdesc.validate.handsim import FINGERS, Hand, find_hand, set_channels
from svhdesc.validate.options import Options
from svhdesc.validate.pair import ModelPair
from svhdesc.validate.report import Check, not_run, skipped, table, verdict

SLIP = 0.005  # m
TIP_GAP = 0.001  # m
PRESHAPE = 1.0  # s, thumb opposition and finger spread alone, the fingers open
CLOSE = 2.0  # s, gravity off, object welded (the damped distal joints close at ~0.9 rad/s)
RELEASE = 0.5  # s over which the weld softens from 2 ms to 2 s
SETTLE = 0.5  # s, gravity off, object free: it finds its place between the fingers
HOLD = 5.0  # s per gravity direction
GRAVITY = 9.81
# Hand-frame gravity directions (right hand; x mirrored for a left one): out of the palm, along the
# fingers towards their tips, across the palm towards the thumb.
DIRECTIONS = {"out of palm": (0.0, 1.0, 0.0), "along fingers": (0.0, 0.0, 1.0), "towards thumb": (-1.0, 0.0, 0.0)}
PRESHAPED = ("Thumb_Opposition", "Finger_Spread")
OBJECT_FRICTION = (0.5, 0.005, 0.0001)  # below the hand's: the hand's friction governs (MuJoCo takes the max)


@dataclass
class GraspResult:
    name: str
    slip: dict[str, float] = field(default_factory=dict)  # direction -> max slip (m)
    contacts: dict[str, int] = field(default_factory=dict)  # finger/palm -> contacts at release
    grip: float = 0.0  # N, normal force on the object at release
    tip_gap: float | None = None  # m, the tips' distance closing on nothing
    tip_others: tuple[str, ...] = ()  # other contacts on the tips' fingers closing on nothing
    state: tuple[np.ndarray, np.ndarray] | None = None  # qpos, ctrl once the object is held (for a picture)
    spec: Any = None  # the scene (hand + object) as MjSpec
    problems: list[str] = field(default_factory=list)


def finger_bodies(model: Any, hand: Hand) -> dict[int, str]:
    """Body id -> finger (the tip's ancestors that lead to no other tip) or 'palm' (the rest of the hand)."""
    tips = {finger: hand.body(model, suffix) for finger, suffix in FINGERS.items()}
    chains: dict[str, set[int]] = {}
    for finger, tip in tips.items():
        chain, body = set(), tip
        while body > 0:
            chain.add(body)
            body = int(model.body_parentid[body])
        chains[finger] = chain
    result = {}
    for body in range(1, model.nbody):
        if not model.body(body).name.startswith(hand.prefix):
            continue
        owners = [f for f, chain in chains.items() if body in chain]
        result[body] = owners[0] if len(owners) == 1 else "palm"
    return result


def _hand_frame(model: Any, data: Any, hand: Hand) -> tuple[np.ndarray, np.ndarray, float]:
    """Base link position, rotation and mirror sign (+1 right hand, -1 left: index on the other side)."""
    base = hand.body(model, "base_link")
    rotation = data.xmat[base].reshape(3, 3).copy()
    local = [(data.xpos[hand.body(model, FINGERS[f])] - data.xpos[base]) @ rotation for f in ("index", "pinky")]
    return data.xpos[base].copy(), rotation, 1.0 if local[1][0] > local[0][0] else -1.0


def _arm_home(model: Any, data: Any) -> None:
    import mujoco

    key = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_KEY, "home")
    if key >= 0:
        mujoco.mj_resetDataKeyframe(model, data, key)


def _key_targets(model: Any, hand: Hand, name: str) -> dict[str, float]:
    """The grasp's channel targets: its keyframe's ctrl on each channel's position servo. The key's qpos is where
    the fingers stop without the object; the targets close past it, so that the servos press with full effort."""
    key = model.key(name)
    return {channel: float(key.ctrl[actuator]) for channel, actuator in hand.actuators.items()}


def _open(model: Any, hand: Hand) -> dict[str, float]:
    return {channel: float(model.jnt_range[joint][0]) for channel, joint in hand.channels.items()}


def _scene(mjcf: Path, grasp: dict[str, Any], world: tuple[np.ndarray, np.ndarray], base: str) -> Any:
    import mujoco

    spec = mujoco.MjSpec.from_file(str(mjcf))
    spec.meshdir = str((mjcf.parent / (spec.meshdir or ".")).resolve())
    position, axis = world
    quat = np.zeros(4)
    mujoco.mju_quatZ2Vec(quat, axis)
    body = spec.worldbody.add_body(name="grasp_object", pos=position, quat=quat)
    body.add_freejoint(name="grasp_object_free")
    kind = {"cylinder": mujoco.mjtGeom.mjGEOM_CYLINDER, "sphere": mujoco.mjtGeom.mjGEOM_SPHERE}.get(
        grasp["object"], mujoco.mjtGeom.mjGEOM_BOX
    )
    size = [*grasp["size"], 0.0, 0.0][:3]
    body.add_geom(
        name="grasp_object",
        type=kind,
        size=size,
        mass=float(grasp["mass"]),
        friction=OBJECT_FRICTION,
        condim=4,
        rgba=(0.85, 0.55, 0.2, 1.0),
    )
    weld = spec.add_equality(
        name="grasp_hold",
        type=mujoco.mjtEq.mjEQ_WELD,
        objtype=mujoco.mjtObj.mjOBJ_BODY,
        name1="grasp_object",
        name2=base,
    )
    weld.solref = (0.002, 1.0)
    spec.worldbody.add_light(pos=(0.0, 0.0, 1.5), dir=(0.0, 0.0, -1.0))
    return spec


def _tips_meet(mjcf: Path, hand: Hand, name: str, tips: list[str]) -> tuple[float, tuple[str, ...]]:
    """Close the posture on nothing: the tips' distance, and other contacts on their fingers."""
    import mujoco

    model = mujoco.MjModel.from_xml_path(str(mjcf))
    model.opt.gravity[:] = 0.0
    data = mujoco.MjData(model)
    _arm_home(model, data)
    set_channels(model, data, hand, _open(model, hand))
    for channel, q in _key_targets(model, hand, name).items():
        data.ctrl[hand.actuators[channel]] = q
    for _ in range(int(round(CLOSE / model.opt.timestep))):
        mujoco.mj_step(model, data)
    owner = finger_bodies(model, hand)
    tip_bodies = {hand.body(model, FINGERS[f]) for f in tips}
    geoms = {
        b: [g for g in range(model.ngeom) if model.geom_bodyid[g] == b and model.geom_contype[g]] for b in tip_bodies
    }
    first, *rest = sorted(tip_bodies)
    gap = np.inf
    for other in rest:
        for g1 in geoms[first]:
            for g2 in geoms[other]:
                gap = min(gap, mujoco.mj_geomDistance(model, data, g1, g2, 0.05, None))
    others = set()
    for i in range(data.ncon):
        b1, b2 = (int(model.geom_bodyid[g]) for g in (data.contact[i].geom1, data.contact[i].geom2))
        if b1 in tip_bodies and b2 in tip_bodies:
            continue
        if owner.get(b1) in tips or owner.get(b2) in tips:
            others.add(f"{model.body(b1).name}-{model.body(b2).name}")
    return float(gap), tuple(sorted(others))


def run_grasp(mjcf: Path, name: str, grasp: dict[str, Any], hand_id: HandId | None) -> GraspResult:
    """The grasp ``name`` of the MJCF ``mjcf``, whose hand is ``hand_id`` (the built model's)."""
    import mujoco

    result = GraspResult(name)
    base_model = mujoco.MjModel.from_xml_path(str(mjcf))
    hand = find_hand(base_model, hand_id)
    if hand is None:
        raise ValueError("no SVH hand (9 channel actuators) in the model")
    if mujoco.mj_name2id(base_model, mujoco.mjtObj.mjOBJ_KEY, name) < 0:
        result.problems.append(f"{name}: no keyframe '{name}' in the MJCF")
        return result
    placement, flip = _placement(base_model, hand, grasp)
    result.spec = _scene(mjcf, grasp, placement, f"{hand.prefix}_base_link")
    sim = _GraspSim.welded(result.spec, hand)
    sim.close(_key_targets(sim.model, hand, name))
    sim.release()
    result.contacts, result.grip = sim.touching()
    result.state = (sim.data.qpos.copy(), sim.data.ctrl.copy())
    _turn_gravity(sim, flip, result)
    result.problems.extend(_hold_problems(result, grasp))
    if grasp.get("tips"):
        result.tip_gap, result.tip_others = _tips_meet(mjcf, hand, name, grasp["tips"])
        result.problems.extend(_pinch_problems(name, grasp["tips"], result.tip_gap, result.tip_others))
    return result


def _placement(model: Any, hand: Hand, grasp: dict[str, Any]) -> tuple[tuple[np.ndarray, np.ndarray], np.ndarray]:
    """The object's world position and unit axis (the grasp's are in the open hand's frame, x mirrored for a left
    hand); and that mirror as a factor on hand-frame vectors."""
    import mujoco

    data = mujoco.MjData(model)
    _arm_home(model, data)
    set_channels(model, data, hand, _open(model, hand))
    mujoco.mj_forward(model, data)
    origin, rotation, mirror = _hand_frame(model, data, hand)
    flip = np.array([mirror, 1.0, 1.0])
    position = origin + rotation @ (flip * np.array(grasp["pos"]))
    axis = rotation @ (flip * np.array(grasp.get("axis", [0.0, 0.0, 1.0])))
    return (position, axis / np.linalg.norm(axis)), flip


@dataclass
class _GraspSim:
    """The hand and the object in one MuJoCo scene, gravity off, the object welded to the hand's base."""

    model: Any
    data: Any
    hand: Hand
    obj: int  # the object's body
    obj_geom: int
    base: int  # the hand's base link
    weld: int  # the equality holding the object
    owner: dict[int, str]  # body -> finger or palm

    @classmethod
    def welded(cls, spec: Any, hand: Hand) -> _GraspSim:
        import mujoco

        model = spec.compile()
        model.opt.gravity[:] = 0.0
        data = mujoco.MjData(model)
        _arm_home(model, data)
        set_channels(model, data, hand, _open(model, hand))
        sim = cls(
            model,
            data,
            hand,
            int(model.body("grasp_object").id),
            int(model.geom("grasp_object").id),
            hand.body(model, "base_link"),
            int(model.equality("grasp_hold").id),
            finger_bodies(model, hand),
        )
        mujoco.mj_forward(model, data)
        sim._anchor_weld()
        return sim

    def _anchor_weld(self) -> None:
        """The weld keeps the object where it is now in the hand's frame (MuJoCo would take qpos0, where an
        arm stands elsewhere): anchored at the object's centre, the base's orientation relative to it."""
        import mujoco

        model, data, weld, base, obj = self.model, self.data, self.weld, self.base, self.obj
        model.eq_data[weld, 0:3] = data.xmat[base].reshape(3, 3).T @ (data.xpos[obj] - data.xpos[base])
        model.eq_data[weld, 3:6] = 0.0
        inverse = np.zeros(4)
        mujoco.mju_negQuat(inverse, data.xquat[obj])
        mujoco.mju_mulQuat(model.eq_data[weld, 6:10], inverse, data.xquat[base])

    def steps(self, seconds: float) -> range:
        return range(int(round(seconds / self.model.opt.timestep)))

    def run(self, seconds: float) -> None:
        import mujoco

        for _ in self.steps(seconds):
            mujoco.mj_step(self.model, self.data)

    def close(self, targets: dict[str, float]) -> None:
        """As a hand grasps: the thumb turns and the fingers spread first, then they close."""
        for channel in PRESHAPED:
            self.data.ctrl[self.hand.actuators[channel]] = targets[channel]
        self.run(PRESHAPE)
        for channel, q in targets.items():
            self.data.ctrl[self.hand.actuators[channel]] = q
        self.run(CLOSE)

    def release(self) -> None:
        """Let go gently: the weld softens over RELEASE s, so the fingers' squeeze does not fling the object;
        then the object settles between the fingers."""
        import mujoco

        steps = int(round(RELEASE / self.model.opt.timestep))
        for step in range(steps):
            self.model.eq_solref[self.weld, 0] = 0.002 * (1000.0 ** (step / steps))
            mujoco.mj_step(self.model, self.data)
        self.data.eq_active[self.weld] = 0
        self.run(SETTLE)

    def in_hand(self) -> np.ndarray:
        data = self.data
        return (data.xpos[self.obj] - data.xpos[self.base]) @ data.xmat[self.base].reshape(3, 3)

    def touching(self) -> tuple[dict[str, int], float]:
        """Contacts on the object per finger (or palm, or world), and their total normal force."""
        import mujoco

        model, data = self.model, self.data
        counts: dict[str, int] = {}
        force, wrench = 0.0, np.zeros(6)
        for i in range(data.ncon):
            contact = data.contact[i]
            if self.obj_geom not in (contact.geom1, contact.geom2):
                continue
            other = int(contact.geom2 if contact.geom1 == self.obj_geom else contact.geom1)
            part = self.owner.get(int(model.geom_bodyid[other]), "world")
            counts[part] = counts.get(part, 0) + 1
            mujoco.mj_contactForce(model, data, i, wrench)
            force += wrench[0]
        return counts, force

    def slip(self, gravity: np.ndarray, held_at: np.ndarray) -> float:
        """HOLD s under `gravity`: the object's largest distance from `held_at` in the hand frame."""
        import mujoco

        self.model.opt.gravity[:] = gravity
        worst = 0.0
        for _ in self.steps(HOLD):
            mujoco.mj_step(self.model, self.data)
            worst = max(worst, float(np.linalg.norm(self.in_hand() - held_at)))
            if worst > 0.05:  # dropped: no need to watch it fall
                break
        return worst


def _turn_gravity(sim: _GraspSim, flip: np.ndarray, result: GraspResult) -> None:
    """Gravity along each hand direction in turn; the slip in each (stops where the simulation diverges)."""
    held_at = sim.in_hand()
    for direction, vector in DIRECTIONS.items():
        world = sim.data.xmat[sim.base].reshape(3, 3) @ (flip * np.array(vector))
        result.slip[direction] = sim.slip(GRAVITY * world, held_at)
        if not np.isfinite(sim.data.qpos).all():
            result.problems.append(f"{result.name}: simulation diverged ({direction})")
            break


def _hold_problems(result: GraspResult, grasp: dict[str, Any]) -> list[str]:
    """Slip over SLIP in any direction; a finger the grasp names that does not touch the object."""
    problems = []
    bad = {d: s for d, s in result.slip.items() if not s < SLIP}
    if bad:
        problems.append(f"{result.name}: slips " + ", ".join(f"{s * 1000:.1f} mm {d}" for d, s in bad.items()))
    missing = [f for f in grasp.get("fingers", []) if not result.contacts.get(f)]
    if missing:
        problems.append(f"{result.name}: {', '.join(missing)} not touching the {grasp['object']}")
    return problems


def _pinch_problems(name: str, tips: list[str], gap: float, others: tuple[str, ...]) -> list[str]:
    """Closing on nothing: the tips farther than TIP_GAP apart, or other contacts on their fingers."""
    problems = []
    if not gap < TIP_GAP:
        problems.append(f"{name}: {' and '.join(tips)} tips {gap * 1000:.1f} mm apart closing on nothing")
    if others:
        problems.append(f"{name}: other contacts on the pinching fingers: {', '.join(others)}")
    return problems


def grasp_picture(
    mjcf: Path, name: str, grasp: dict[str, Any], hand_id: HandId | None, out: Path, size: tuple[int, int]
) -> GraspResult:
    """Render the hand holding the object (before gravity turns) to ``out``, looking into the palm."""
    from svhdesc.validate.render import render

    result = run_grasp(mjcf, name, grasp, hand_id)
    if result.spec is None or result.state is None:
        raise SvhdescError(f"grasp {name}: {'; '.join(result.problems) or 'not simulated'}")
    spec = result.spec
    qpos, ctrl = result.state
    spec.add_key(name="held", qpos=qpos, ctrl=ctrl)
    spec.visual.global_.azimuth = -70.0  # into the palm; the render's studio sets the lights
    spec.visual.global_.elevation = -15.0
    with tempfile.TemporaryDirectory() as folder:
        scene = Path(folder) / f"grasp_{name}.xml"
        scene.write_text(spec.to_xml())
        render(scene, out, "held", size)
    return result


def render_grasp(target: Path, name: str, out: Path, size: tuple[int, int]) -> GraspResult:
    """``svhdesc render --grasp``: the configured grasp ``name`` of a built variant (directory or MJCF)."""
    mjcf = target if target.is_file() else target / f"{target.name}.xml"
    built = Model(mjcf.stem, mjcf.parent)
    configuration = built.configuration()
    grasps = dict(configuration.settings.grasps) if configuration is not None else {}
    if name not in grasps:
        raise SvhdescError(f"{mjcf}: no grasp '{name}' configured (grasps: {', '.join(grasps) or 'none'})")
    return grasp_picture(mjcf, name, grasps[name], built.hand, out, size)


def configured_grasps(pair: ModelPair) -> dict[str, Any] | None:
    if pair.configuration is None:
        return None
    return dict(pair.configuration.settings.grasps)


def check_grasps(pair: ModelPair, options: Options) -> list[Check]:
    bound = f"slip < {SLIP * 1000:g} mm, {HOLD:g} s per gravity direction"
    if pair.model is None:
        return [not_run("grasps", "the MJCF does not compile", bound)]
    if find_hand(pair.model, pair.hand) is None:
        return [skipped("grasps", "no SVH hand", bound)]
    grasps = configured_grasps(pair)
    if not grasps:
        return [skipped("grasps", "no grasps configured", bound)]
    rows, problems, figures, worst = [], [], {}, 0.0
    for name, grasp in grasps.items():
        result = run_grasp(pair.mjcf_path, name, grasp, pair.hand)
        problems.extend(result.problems)
        slip = max(result.slip.values()) if result.slip else float("nan")
        worst = max(worst, slip) if np.isfinite(slip) else worst
        figures[name] = {
            "object": grasp["object"],
            "slip_m": result.slip,
            "contacts": result.contacts,
            "grip_force_N": result.grip,
            "tip_gap_m": result.tip_gap,
            "passed": not result.problems,
        }
        contacts = " ".join(f"{k}:{v}" for k, v in sorted(result.contacts.items()))
        slips = "/".join(f"{result.slip.get(d, float('nan')) * 1000:.2f}" for d in DIRECTIONS)
        gap = "" if result.tip_gap is None else f"{result.tip_gap * 1000:.2f}"
        rows.append([name, grasp["object"], slips, contacts or "-", f"{result.grip:.1f}", gap])
    header = ["grasp", "object", "slip mm (" + " / ".join(DIRECTIONS) + ")", "contacts", "grip N", "tip gap mm"]
    return [
        Check(
            "grasps",
            verdict(not problems),
            f"worst slip {worst * 1000:.2f} mm",
            bound,
            "; ".join(problems) or f"{len(rows)} grasps held",
            figures,
            table=table(rows, header),
        )
    ]
