"""What a compiled model exposes to a controller: joints, hand channels, arm joints, couplings."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from svhdesc.model import DRIVER_CHANNELS, Coupling, HandId, couplings, scalar_joints, velocity_servos


@dataclass(frozen=True)
class RobotInfo:
    joints: tuple[str, ...]  # every 1-DoF joint, in qpos order
    actuators: tuple[str, ...]  # actuator names (= the joint each drives)
    hand_channels: tuple[str, ...]  # actuated hand joints, in the driver's channel order
    arm_joints: tuple[str, ...]  # every other actuated joint on a position servo
    hand_prefix: str | None  # e.g. "right_hand": the built model's (svhdesc.model.Model.hand)
    couplings: tuple[Coupling, ...]  # the MJCF's joint equalities (svhdesc.model.Coupling)
    keyframes: tuple[str, ...]
    velocity_joints: tuple[str, ...] = ()  # joints on a velocity servo (joints.NAME.servo: velocity)


def describe(model: Any, hand: HandId | None) -> RobotInfo:
    """``hand``: the built model's hand; its channels are the actuated joints named ``<prefix>_<driver channel>``."""
    import mujoco

    joints = tuple(model.joint(j).name for j in scalar_joints(model))
    actuators = []
    for a in range(model.nu):
        if int(model.actuator_trntype[a]) != int(mujoco.mjtTrn.mjTRN_JOINT):
            continue
        actuators.append(model.joint(model.actuator_trnid[a, 0]).name)
    named = [hand.name(c) for c in DRIVER_CHANNELS] if hand is not None else []
    channels = tuple(name for name in named if name in actuators)
    velocity = velocity_servos(model)
    return RobotInfo(
        joints=joints,
        actuators=tuple(actuators),
        hand_channels=channels,
        arm_joints=tuple(a for a in actuators if a not in channels and a not in velocity),
        hand_prefix=hand.prefix if hand is not None and channels else None,
        couplings=tuple(couplings(model)),
        keyframes=tuple(model.key(k).name for k in range(model.nkey)),
        velocity_joints=tuple(a for a in actuators if a in velocity),
    )
