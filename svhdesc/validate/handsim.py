"""The hand in a compiled MJCF, as the contact checks drive it: channels, their followers, poses.

Read from the model (actuators and joint equalities), so a check drives what the file says, not what the build
meant; which names are the hand's comes from the built model's ``HandId`` (its manifest), never from the names.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from svhdesc.ir import Channel
from svhdesc.model import HandId, actuated_joints, couplings
from svhdesc.polynomial import polyval
from svhdesc.validate.pair import ModelPair

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
class HandParts:
    """Any robot's hand as the checks that drive it through its range or load it see it: its channel joints with
    their commanded ranges (in the coupling spec's order) and its fingertip bodies (in model order)."""

    prefix: str  # what the names are shown without ("" for a hand without one)
    channels: dict[str, tuple[float, float]]  # joint name -> commanded range
    tips: list[int]  # body ids

    def short(self, name: str) -> str:
        return name.removeprefix(f"{self.prefix}_") if self.prefix else name


def hand_parts(pair: ModelPair) -> HandParts:
    """The built model's hand (``pair.hand``): the channels of the configuration that built it (its coupling spec)
    and its hand.fingertips, each ``<prefix>_<name>`` where the model has that, else the name itself; without a
    configuration, the SVH's driver channels and fingertip links under the built model's prefix."""
    model = pair.model
    actuated = actuated_joints(model)
    bodies = {model.body(b).name: b for b in range(model.nbody)}
    hand_id = pair.hand or HandId(None, None)
    configuration = pair.configuration
    if configuration is not None:
        channel_names, tip_names = list(configuration.channels()), list(configuration.settings.hand.fingertips)
    elif hand_id.prefix is not None:  # a built SVH without its config at hand: the driver's channels and tips
        channel_names, tip_names = [*TIP_OF_CHANNEL, "Finger_Spread"], list(FINGERS.values())
    else:
        channel_names, tip_names = [], []

    def named(name: str, known: Any) -> str:
        return hand_id.name(name) if hand_id.name(name) in known else name

    joints = [named(c, actuated) for c in channel_names]
    tips = [bodies[named(t, bodies)] for t in tip_names if named(t, bodies) in bodies]
    return HandParts(hand_id.prefix or "", {j: actuated[j] for j in joints if j in actuated}, sorted(tips))


@dataclass(frozen=True)
class Hand:
    prefix: str
    channels: dict[str, int]  # unprefixed channel name -> joint id
    actuators: dict[str, int]  # unprefixed channel name -> actuator id
    followers: dict[int, list[tuple[int, tuple[float, ...]]]]  # channel joint -> (joint, poly coeffs)

    def body(self, model: Any, suffix: str) -> int:
        return int(model.body(f"{self.prefix}_{suffix}").id)


def find_hand(model: Any, hand_id: HandId | None) -> Hand | None:
    """The SVH of the built model's ``hand_id`` (its manifest's): the channels (actuated joints named
    ``<prefix>_<channel>``) and their coupled joints; None unless all nine are there."""
    if hand_id is None or hand_id.prefix is None:
        return None
    channels, actuators = {}, {}
    wanted = {hand_id.name(channel): channel for channel in (*TIP_OF_CHANNEL, "Finger_Spread")}
    for a in range(model.nu):
        joint = int(model.actuator_trnid[a, 0])
        channel = wanted.get(model.joint(joint).name)
        if channel is not None:
            channels[channel], actuators[channel] = joint, a
    if len(channels) < 9:
        return None
    prefix = hand_id.prefix
    followers: dict[int, list[tuple[int, tuple[float, ...]]]] = {j: [] for j in channels.values()}
    for eq in couplings(model):
        leader = int(model.joint(eq.leader).id)
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
            data.qpos[model.jnt_qposadr[follower]] = polyval(coeffs, q)
    data.qvel[:] = 0.0


def hold_arm(model: Any, data: Any, hand: Hand) -> None:
    """The arm, if any, at its keyframe ``home`` (a pose its config declares clear of itself; qpos 0 may lie outside
    an arm joint's range, as the Panda's elbow's, or fold the arm onto the hand) with every servo that is not the
    hand's commanded there: the arm stays put while the hand works."""
    import mujoco

    mine = set(hand.actuators.values())
    if len(mine) == model.nu:
        return
    home = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_KEY, "home")
    if home >= 0:
        data.qpos[:] = model.key_qpos[home]
    for actuator in range(model.nu):
        if actuator in mine:
            continue
        joint = int(model.actuator_trnid[actuator, 0])
        address = model.jnt_qposadr[joint]
        if model.jnt_limited[joint]:
            data.qpos[address] = np.clip(data.qpos[address], *model.jnt_range[joint])
        data.ctrl[actuator] = data.qpos[address]


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
    return pair.configuration.channels() if pair.configuration is not None else None


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
