"""The hand in a compiled MJCF, as the contact checks drive it: channels, their followers, poses.

Read from the model alone (actuators and joint equalities), so a check drives what the file says,
not what the build meant.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from svhdesc.compiler.settings.coupling import load_spec
from svhdesc.ir import Channel
from svhdesc.validate.pair import ModelPair, joint_equalities

# Distal link of each finger, by the channel that moves it (the vendor's link letters).
TIP_OF_CHANNEL = {
    "Thumb_Flexion": "c",
    "Thumb_Opposition": "c",
    "Index_Finger_Distal": "t",
    "Index_Finger_Proximal": "t",
    "Middle_Finger_Distal": "s",
    "Middle_Finger_Proximal": "s",
    "Ring_Finger": "r",
    "Pinky": "q",
}
FINGERS = {"thumb": "c", "index": "t", "middle": "s", "ring": "r", "pinky": "q"}


@dataclass(frozen=True)
class Hand:
    prefix: str
    channels: dict[str, int]  # unprefixed channel name -> joint id
    actuators: dict[str, int]  # unprefixed channel name -> actuator id
    followers: dict[int, list[tuple[int, tuple[float, ...]]]]  # channel joint -> (joint, poly coeffs)

    def body(self, model: Any, suffix: str) -> int:
        return int(model.body(f"{self.prefix}_{suffix}").id)


def find_hand(model: Any) -> Hand | None:
    """The hand's channels (actuated joints named <prefix>_<channel>) and their coupled joints."""
    channels, actuators, prefix = {}, {}, ""
    for a in range(model.nu):
        joint = int(model.actuator_trnid[a, 0])
        name = model.joint(joint).name
        for channel in (*TIP_OF_CHANNEL, "Finger_Spread"):
            if name.endswith(f"_{channel}"):
                channels[channel], actuators[channel] = joint, a
                prefix = name[: -len(channel) - 1]
    if len(channels) < 9:
        return None
    followers: dict[int, list[tuple[int, tuple[float, ...]]]] = {j: [] for j in channels.values()}
    for eq in joint_equalities(model):
        leader = int(model.joint(eq.channel).id)
        if leader in followers:
            followers[leader].append((int(model.joint(eq.joint).id), eq.coeffs))
    return Hand(prefix, channels, actuators, followers)


def set_channels(model: Any, data: Any, hand: Hand, targets: dict[str, float]) -> None:
    """Channels (and their coupled joints) to ``targets``, at rest, servos commanded there."""
    for channel, q in targets.items():
        joint = hand.channels[channel]
        data.qpos[model.jnt_qposadr[joint]] = q
        data.ctrl[hand.actuators[channel]] = q
        for follower, coeffs in hand.followers[joint]:
            data.qpos[model.jnt_qposadr[follower]] = sum(c * q**k for k, c in enumerate(coeffs))
    data.qvel[:] = 0.0


def channel_jacobian(model: Any, data: Any, hand: Hand, channel: str, point: np.ndarray, body: int) -> np.ndarray:
    """d(point)/d(channel), its coupled joints following (point fixed to ``body``, world frame)."""
    import mujoco

    jacp = np.zeros((3, model.nv))
    mujoco.mj_jac(model, data, jacp, None, point, body)
    joint = hand.channels[channel]
    q = data.qpos[model.jnt_qposadr[joint]]
    column = jacp[:, model.jnt_dofadr[joint]].copy()
    for follower, coeffs in hand.followers[joint]:
        slope = sum(k * c * q ** (k - 1) for k, c in enumerate(coeffs) if k)
        column += slope * jacp[:, model.jnt_dofadr[follower]]
    return column


def body_vertices(model: Any, data: Any, body: int) -> np.ndarray:
    """World positions of the vertices of ``body``'s colliding mesh geoms (centres of other geoms)."""
    points = []
    for g in range(model.ngeom):
        if model.geom_bodyid[g] != body or not (model.geom_contype[g] or model.geom_conaffinity[g]):
            continue
        rotation = data.geom_xmat[g].reshape(3, 3)
        mesh = int(model.geom_dataid[g])
        if mesh >= 0:
            start, count = model.mesh_vertadr[mesh], model.mesh_vertnum[mesh]
            points.append(model.mesh_vert[start : start + count] @ rotation.T + data.geom_xpos[g])
        else:
            points.append(data.geom_xpos[g][None, :])
    return np.vstack(points) if points else np.zeros((0, 3))


def configured_channels(pair: ModelPair) -> dict[str, Channel] | None:
    """The coupling spec's channels of the configuration that built ``pair`` (None if none did)."""
    if pair.variant is None:
        return None
    if pair.variant.coupling_path is None:
        return {}  # configured without a coupling spec: no channels
    spec = load_spec(pair.variant.coupling_path)
    return {c.name: c for c in spec.channels}


def contact_forces(model: Any, data: Any, geoms: set[int]) -> list[tuple[int, int, float]]:
    """(geom touching one of ``geoms``, that geom, normal force N) for each active contact."""
    import mujoco

    result = []
    wrench = np.zeros(6)
    for i in range(data.ncon):
        contact = data.contact[i]
        g1, g2 = int(contact.geom1), int(contact.geom2)
        if g1 in geoms or g2 in geoms:
            mujoco.mj_contactForce(model, data, i, wrench)
            other, mine = (g2, g1) if g1 in geoms else (g1, g2)
            result.append((other, mine, float(wrench[0])))
    return result
