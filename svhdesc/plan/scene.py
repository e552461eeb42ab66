"""Collision checking for the planner with MuJoCo's collision detection on the model's collision geoms
(the same convex hulls the simulation uses), in the scene the simulation loads (scene.xml: the floor and, for an
arm, its pedestal), plus obstacles (boxes, cylinders) in the world.

MoveIt's rules, not the simulator's: the MJCF's own <exclude> pairs and MuJoCo's parent-child filter are
dropped, and only the SRDF's disable_collisions pairs are skipped. Coupled joints follow their channels
through the model's joint equalities (the coupling polynomials).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import replace

import numpy as np

from svhdesc.errors import SvhdescError
from svhdesc.extras import require
from svhdesc.model import couplings, get
from svhdesc.plan.config import MoveItConfig
from svhdesc.polynomial import polyval
from svhdesc.sim.objects import Obstacle, add_objects

# Pairs that touch in the state a query starts from (by up to 0.5 mm: measured states, e.g. fingers resting on
# each other in a grasp) may go on touching that much; everything else must stay clear. MoveIt's
# FixStartStateCollision adapter would nudge such a start state instead.
TOUCH = 5e-4
CLEAR = 1e-6


class CollisionScene:
    def __init__(self, variant: str, config: MoveItConfig, obstacles: Sequence[Obstacle] = ()) -> None:
        mujoco = require("mujoco", "planning", "sim")
        self._mj = mujoco
        # The simulation's own scene (svhdesc.sim.runtime.Simulation loads it too): what `plan --execute` runs in.
        # Geoms welded to the world (floor, pedestal, the arm's base) never collide with each other in MuJoCo.
        spec = mujoco.MjSpec.from_file(str(get(variant).scene_path))
        for exclude in list(spec.excludes):
            spec.delete(exclude)
        bodies = {b.name for b in spec.bodies}
        for pair in sorted(tuple(sorted(p)) for p in config.disabled):  # SRDF pairs: skipped in the narrow phase
            if len(pair) == 2 and set(pair) <= bodies:
                spec.add_exclude(bodyname1=pair[0], bodyname2=pair[1])
        add_objects(spec, [replace(o, mass=None) for o in obstacles])  # movable objects are obstacles here
        self.model = spec.compile()
        self.model.opt.disableflags |= int(mujoco.mjtDisableBit.mjDSBL_FILTERPARENT)
        self.data = mujoco.MjData(self.model)
        self.config = config
        self.obstacles = tuple(obstacles)
        model = self.model
        self._qpos = {model.joint(j).name: int(model.joint(j).qposadr[0]) for j in range(model.njnt)}
        self._body = [model.body(b).name for b in range(model.nbody)]
        # Coupled joint = poly(channel) (mjEQ_JOINT: q1 - q1_0 = sum c_k (q2 - q2_0)^k), vectorised.
        found = couplings(model)
        coupled = np.array([model.joint(c.joint).qposadr[0] for c in found], dtype=int)
        channel = np.array([model.joint(c.leader).qposadr[0] for c in found], dtype=int)
        self._coupled, self._channel = coupled, channel
        self._coupled0, self._channel0 = model.qpos0[coupled].copy(), model.qpos0[channel].copy()
        self._poly = np.array([c.coeffs for c in found], dtype=float).reshape(len(found), 5)
        # valid()'s table, by body index: the pairs that may touch by up to TOUCH (refilled by set_state). The
        # SRDF's pairs need none: they are the excludes above, so MuJoCo makes no contact between them.
        self._index = {name: b for b, name in enumerate(self._body)}
        self._may_touch = np.zeros((model.nbody, model.nbody), dtype=bool)
        self.checks = 0
        self.touching: frozenset = frozenset()

    def joint_index(self, names: Sequence[str]) -> np.ndarray:
        missing = [n for n in names if n not in self._qpos]
        if missing:
            raise SvhdescError(f"joints {missing} are not in the model")
        return np.array([self._qpos[n] for n in names])

    def set_state(self, positions: Mapping[str, float]) -> None:
        """The state a query starts from; its pairs touching by up to TOUCH may keep touching."""
        for name, value in positions.items():
            self.data.qpos[self._qpos[name]] = value
        self._couple()
        self.touching = frozenset()
        self.touching = frozenset(frozenset((a, b)) for a, b, depth in self.colliding_pairs() if depth <= TOUCH)
        self._may_touch[:] = False
        for pair in self.touching:
            a, b = (self._index[name] for name in pair)
            self._may_touch[a, b] = self._may_touch[b, a] = True

    def _couple(self) -> None:
        qpos = self.data.qpos
        x = qpos[self._channel] - self._channel0
        qpos[self._coupled] = self._coupled0 + polyval(self._poly.T, x)  # one row of coefficients per power

    def _collide(self, index: np.ndarray | None, values: Sequence[float] | None) -> int:
        """MuJoCo's contacts at the current state, or at ``values`` of the joints at ``index``; how many."""
        mujoco, model, data = self._mj, self.model, self.data
        if index is not None and values is not None:
            data.qpos[index] = values
            self._couple()
        mujoco.mj_kinematics(model, data)
        mujoco.mj_collision(model, data)
        self.checks += 1
        return int(data.ncon)

    def colliding_pairs(self, index: np.ndarray | None = None, values: Sequence[float] | None = None) -> list:
        """(body, body, depth) of every contact the SRDF does not disable, at the current (or given) state."""
        model, data = self.model, self.data
        if not self._collide(index, values):
            return []
        found = []
        for contact in data.contact[: data.ncon]:
            if contact.dist >= -CLEAR:
                continue
            a = self._body[model.geom_bodyid[contact.geom[0]]]
            b = self._body[model.geom_bodyid[contact.geom[1]]]
            pair = frozenset((a, b))
            if a == b or pair in self.config.disabled or (contact.dist >= -TOUCH and pair in self.touching):
                continue
            found.append((a, b, -float(contact.dist)))
        return found

    def valid(self, index: np.ndarray, values: Sequence[float]) -> bool:
        """No pair in ``colliding_pairs`` at the given state, decided on MuJoCo's contact arrays at once: the
        planner's hot path (a state in collision has tens of contacts, each a Python object to colliding_pairs)."""
        if not self._collide(index, values):
            return True
        contacts = self.data.contact
        dist = contacts.dist
        deep = dist < -CLEAR
        if not deep.any():
            return True
        bodies = self.model.geom_bodyid[contacts.geom[deep]]
        first, second = bodies[:, 0], bodies[:, 1]
        return bool((self._may_touch[first, second] & (dist[deep] >= -TOUCH)).all())
