"""What carries a fingertip's contact: the servos, or the joint stops the contact pushes the finger into.

A surface that pushes a finger against its joint limit is held by the limit constraint, however weak the servos:
the contact force then measures the stop's stiffness, not the servos' press. Per joint of the fingertip's chain
(the joints between the tip's body and the world), the torque the contact puts on the joint (J^T f of the
selected contacts) is compared with the torque its joint-limit constraint holds.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass
from typing import Any

import numpy as np

STOP_SHARE_BOUND = 0.5  # above this share of the contact's load on the joints, the stops hold the contact


@dataclass(frozen=True)
class Load:
    """The contact's load on each joint of the chain and what the joint's stop holds, N m (N on a slide)."""

    contact: dict[str, float]
    stops: dict[str, float]  # joints at a stop carrying force, only

    @property
    def stop_share(self) -> float:
        """The share of the contact's load on the joints that their stops hold (0 without a load)."""
        total = sum(self.contact.values())
        held = sum(min(self.stops.get(name, 0.0), load) for name, load in self.contact.items())
        return held / total if total > 0 else 0.0

    @property
    def held_by_stops(self) -> bool:
        return self.stop_share > STOP_SHARE_BOUND

    def stopped_joints(self) -> list[str]:
        """The chain's joints whose stops hold part of the contact's load, most loaded first."""
        held = {name: min(force, self.contact.get(name, 0.0)) for name, force in self.stops.items()}
        return [name for name, force in sorted(held.items(), key=lambda item: -item[1]) if force > 0]

    def describe(self) -> str:
        if not self.held_by_stops:
            return f"the servos hold the contact ({self.stop_share:.0%} of its load on joint stops)"
        return (
            f"the joint stops hold {self.stop_share:.0%} of the contact's load ({', '.join(self.stopped_joints())}): "
            "the surface pushes the finger into its limits, so the force measures the stops, not the servos' press"
        )


def chain(model: Any, body: int) -> list[int]:
    """The hinge and slide joints between ``body`` and the world."""
    import mujoco

    scalar = {int(mujoco.mjtJoint.mjJNT_HINGE), int(mujoco.mjtJoint.mjJNT_SLIDE)}
    joints = []
    while body > 0:
        start, count = int(model.body_jntadr[body]), int(model.body_jntnum[body])
        joints += [j for j in range(start, start + count) if int(model.jnt_type[j]) in scalar]
        body = int(model.body_parentid[body])
    return joints


def load(model: Any, data: Any, body: int, contacts: Iterable[int]) -> Load:
    """What ``contacts`` (indices into data.contact, touching ``body``) put on ``body``'s chain, and its stops."""
    import mujoco

    joints = chain(model, body)
    generalized = np.zeros(model.nv)
    wrench = np.zeros(6)
    jacobian = np.zeros((3, model.nv))
    for index in contacts:
        contact = data.contact[index]
        mujoco.mj_contactForce(model, data, index, wrench)
        force = contact.frame.reshape(3, 3).T @ wrench[:3]  # contact frame -> world
        mujoco.mj_jac(model, data, jacobian, None, contact.pos, body)
        generalized += jacobian.T @ force
    names = {j: model.joint(j).name for j in joints}
    on_joints = {names[j]: abs(float(generalized[model.jnt_dofadr[j]])) for j in joints}
    limit = int(mujoco.mjtConstraint.mjCNSTR_LIMIT_JOINT)
    stops: dict[str, float] = {}
    for row in range(data.nefc):
        joint = int(data.efc_id[row])
        if int(data.efc_type[row]) == limit and joint in names and data.efc_force[row] != 0:
            stops[names[joint]] = stops.get(names[joint], 0.0) + abs(float(data.efc_force[row]))
    return Load(on_joints, stops)
