"""What a compiled model exposes to a controller: joints, hand channels, arm joints, couplings."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from svhdesc.model import DRIVER_CHANNELS, Coupling, couplings, scalar_joints


@dataclass(frozen=True)
class RobotInfo:
    joints: tuple[str, ...]  # every 1-DoF joint, in qpos order
    actuators: tuple[str, ...]  # actuator names (= the joint each drives)
    hand_channels: tuple[str, ...]  # actuated hand joints, in the driver's channel order
    arm_joints: tuple[str, ...]  # every other actuated joint
    hand_prefix: str | None  # e.g. "right_hand"
    couplings: tuple[Coupling, ...]  # the MJCF's joint equalities (svhdesc.model.Coupling)
    keyframes: tuple[str, ...]


def describe(model: Any) -> RobotInfo:
    import mujoco

    joints = tuple(model.joint(j).name for j in scalar_joints(model))
    actuators = []
    for a in range(model.nu):
        if int(model.actuator_trntype[a]) != int(mujoco.mjtTrn.mjTRN_JOINT):
            continue
        actuators.append(model.joint(model.actuator_trnid[a, 0]).name)
    by_channel = {}
    for name in actuators:
        for channel in DRIVER_CHANNELS:
            if name.endswith("_" + channel):
                by_channel[channel] = name
    hand = tuple(by_channel[c] for c in DRIVER_CHANNELS if c in by_channel)
    prefix = hand[0][: -len(DRIVER_CHANNELS[0]) - 1] if hand and hand[0].endswith(DRIVER_CHANNELS[0]) else None
    return RobotInfo(
        joints=joints,
        actuators=tuple(actuators),
        hand_channels=hand,
        arm_joints=tuple(a for a in actuators if a not in hand),
        hand_prefix=prefix,
        couplings=tuple(couplings(model)),
        keyframes=tuple(model.key(k).name for k in range(model.nkey)),
    )
