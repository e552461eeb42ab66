"""Every hand channel reaches both ends of its range with contacts and gravity on, as on the real hand.

The channels are those of the coupling spec that built the model (any robot's hand or gripper; an SVH recognised
by its joint names when no configuration is known).

From ``home``, each channel alone is commanded to its lower end, then its upper end, then back, the others
held where they are; each end must be reached within TOLERANCE of the range, and each coupled joint must
reach its polynomial's image of the channel's ends. A channel that stops short names the body pair in
contact with the moving finger: the collision geometry that blocks it.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from svhdesc.model import couplings
from svhdesc.polynomial import polyval
from svhdesc.validate.handsim import hand_parts
from svhdesc.validate.options import Options
from svhdesc.validate.pair import ModelPair
from svhdesc.validate.report import Check, fmt, not_run, skipped, table, verdict

TOLERANCE = 0.01  # of the channel's range
MAX_TIME = 3.0  # s per stroke (the slowest channel, 1 rad at 1 rad/s, settles in under 2 s)
SETTLED_SPEED = 1e-3  # rad/s: a stroke ends early once every hand joint is this still near its goal


def _subtree(model: Any, body: int) -> set[int]:
    bodies = {body}
    for b in range(body + 1, model.nbody):
        if int(model.body_parentid[b]) in bodies:
            bodies.add(b)
    return bodies


def _stroke(model: Any, data: Any, actuator: int, goal: float, adr: int, dofs: np.ndarray, tol: float) -> None:
    import mujoco

    data.ctrl[actuator] = goal
    for step in range(int(round(MAX_TIME / model.opt.timestep))):
        mujoco.mj_step(model, data)
        if step % 20 == 0 and abs(data.qpos[adr] - goal) < tol / 4 and np.all(np.abs(data.qvel[dofs]) < SETTLED_SPEED):
            return


def _blocking(model: Any, data: Any, moving: set[int]) -> list[str]:
    """Body pairs in contact with one body moving with the channel (deepest first)."""
    pairs: dict[tuple[str, str], float] = {}
    for contact in data.contact[: data.ncon]:
        b1, b2 = int(model.geom_bodyid[contact.geom1]), int(model.geom_bodyid[contact.geom2])
        if (b1 in moving) != (b2 in moving):
            key = (model.body(b1).name, model.body(b2).name)
            pairs[key] = min(pairs.get(key, 0.0), float(contact.dist))
    return [f"{a}/{b}" for (a, b), _ in sorted(pairs.items(), key=lambda kv: kv[1])]


def check_range_of_motion(pair: ModelPair, options: Options) -> list[Check]:
    import mujoco

    bound = f"each end within {TOLERANCE:.0%} of the range"
    if pair.model is None:
        return [not_run("range_of_motion", "the MJCF does not compile", bound)]
    model = pair.model
    hand = hand_parts(pair)
    if not hand.channels:
        return [skipped("range_of_motion", "no hand channels", bound)]
    channels, prefix = hand.channels, hand.prefix
    strokes = _Strokes(
        model,
        mujoco.MjData(model),
        mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_KEY, "home"),
        np.array([model.jnt_dofadr[model.joint(n).id] for n in channels], dtype=int),
        couplings(model),
        {model.joint(int(model.actuator_trnid[a, 0])).name: a for a in range(model.nu)},
        prefix,
    )
    problems: list[str] = []
    results = {name: strokes.channel(name, low, high, problems) for name, (low, high) in channels.items()}
    worst = min(results, key=lambda n: results[n]["fraction"]) if results else None
    rows = [
        [
            hand.short(n),
            f"{r['range'][0]:.4f} .. {r['range'][1]:.4f}",
            f"{r['reached'][0]:.4f} .. {r['reached'][1]:.4f}",
            f"{100 * r['fraction']:.1f} %",
        ]
        for n, r in results.items()
    ]
    return [
        Check(
            "range_of_motion",
            verdict(not problems),
            f"worst {fmt(100 * results[worst]['fraction'])} % ({hand.short(worst)})" if worst else "-",
            bound,
            "; ".join(problems) or f"{len(results)} channels, contacts and gravity on, from 'home'",
            {"channels": results, "tolerance": TOLERANCE},
            table=table(rows, ["channel", "range (rad)", "reached (rad)", "reached"]),
        )
    ]


@dataclass
class _Strokes:
    """The hand's channels driven one at a time from ``home`` (the model's reset state without one); names are
    shown without ``prefix``."""

    model: Any
    data: Any
    home: int  # keyframe id, < 0 where there is none
    hand_dofs: np.ndarray  # the channels' dofs: a stroke ends once they are still
    equalities: list[Any]  # svhdesc.model.Coupling
    actuator_of: dict[str, int]  # joint -> actuator
    prefix: str

    def channel(self, name: str, low: float, high: float, problems: list[str]) -> dict[str, Any]:
        """Lower end, upper end, lower end again: what the channel and its followers reached (and what blocked
        it); each end missed is appended to `problems`."""
        import mujoco

        model, data = self.model, self.data
        if self.home >= 0:
            mujoco.mj_resetDataKeyframe(model, data, self.home)
        else:
            mujoco.mj_resetData(model, data)
        joint = model.joint(name).id
        shown = name.removeprefix(f"{self.prefix}_") if self.prefix else name
        adr, actuator = int(model.jnt_qposadr[joint]), self.actuator_of[name]
        tol = TOLERANCE * (high - low)
        followers = [e for e in self.equalities if e.leader == name]
        moving = set().union(
            _subtree(model, int(model.jnt_bodyid[joint])),
            *(_subtree(model, int(model.jnt_bodyid[model.joint(e.joint).id])) for e in followers),
        )
        reached: dict[str, float] = {}
        entry: dict[str, Any] = {"range": [low, high], "followers": {}}
        for label, goal in (("start", low), ("upper", high), ("lower", low)):
            _stroke(model, data, actuator, goal, adr, self.hand_dofs, tol)
            q = reached[label] = float(data.qpos[adr])
            if abs(q - goal) > tol:
                blockers = _blocking(model, data, moving)
                entry.setdefault("blocked_by", {})[label] = blockers
                problems.append(
                    f"{shown} stops at {q:.3f} of {goal:.4g} going {label}"
                    + (f", blocked by {blockers[0]}" if blockers else "")
                )
            for e in followers:
                expected = float(polyval(e.coeffs, goal))
                got = float(data.qpos[model.jnt_qposadr[model.joint(e.joint).id]])
                span = abs(float(polyval(e.coeffs, high)) - float(polyval(e.coeffs, low))) or 1.0
                entry["followers"].setdefault(e.joint, {})[label] = got
                if abs(got - expected) > TOLERANCE * span and abs(q - goal) <= tol:
                    problems.append(f"{e.joint} reaches {got:.3f}, not {expected:.3f}, at {name} {label}")
        entry["reached"] = [reached["lower"], reached["upper"]]
        entry["fraction"] = (reached["upper"] - reached["lower"]) / (high - low) if high > low else 1.0
        return entry
