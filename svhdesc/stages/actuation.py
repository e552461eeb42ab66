"""Actuators, transmissions, joint dynamics, keyframes and the fingertip force sensor."""

from __future__ import annotations

from dataclasses import replace
from typing import Any

import numpy as np

from ..coupling import propagate
from ..errors import SvhdescError
from ..ir import Actuator, Channel, ForceSensor, Joint, Keyframe, Robot, Transmission
from ..yamlio import where

INTERFACES = {
    "position": "hardware_interface/PositionJointInterface",
    "effort": "hardware_interface/EffortJointInterface",
}


def _per_joint(value: Any, count: int, what: str) -> list[float]:
    values = value if isinstance(value, list) else [value] * count
    if len(values) != count:
        raise SvhdescError(f"{what}: expected {count} values, got {len(values)}")
    return [float(v) for v in values]


def arm_joints(robot: Robot, arm: dict[str, Any]) -> list[str]:
    if not arm.get("enabled"):
        return []
    names = {j.name for j in robot.joints}
    missing = [j for j in arm["joints"] if j not in names]
    if missing:
        raise SvhdescError(f"arm joints not in the robot: {missing}")
    return list(arm["joints"])


def add_actuation(robot: Robot, settings: dict[str, Any]) -> Robot:
    """Channels and arm joints become position actuators with ros_control transmissions."""
    hand, arm = settings["hand"], settings["arm"]
    interface = INTERFACES.get(settings["transmissions"].get("interface", "position"))
    if interface is None:
        raise SvhdescError(f"transmissions.interface must be one of {sorted(INTERFACES)}")
    joints = {j.name: j for j in robot.joints}
    channel_of = {c.joint: c for c in robot.channels}
    followers = {j.name: j.mimic.joint for j in robot.joints if j.mimic}
    actuators = []
    for channel in robot.channels:
        actuators.append(
            Actuator(
                channel.joint,
                channel.joint,
                channel.lower,
                channel.upper,
                channel.effort,
                float(hand["kp"]),
                float(hand.get("dampratio", 1.0)),
            )
        )
    names = arm_joints(robot, arm)
    kps = _per_joint(arm.get("kp", 1000.0), len(names), "arm.kp") if names else []
    for name, kp in zip(names, kps):
        j = joints[name]
        actuators.append(Actuator(name, name, j.lower, j.upper, j.effort, kp, float(arm.get("dampratio", 1.0))))
    # Joint dynamics: channel efforts/velocities come from the spec; followers share their channel's
    # effort, and move as fast as the coupling makes them (j4 turns 1.45x as fast as Thumb_Flexion):
    # a follower capped at the channel's speed lags behind it in engines that enforce velocity limits.
    updated = []
    for joint in robot.joints:
        if joint.name in channel_of or joint.name in followers:
            channel = channel_of[followers.get(joint.name, joint.name)]
            solref = hand.get("limit_solref")
            joint = replace(
                joint,
                effort=channel.effort,
                velocity=channel.velocity * _speed_ratio(joint, channel),
                damping=float(hand.get("joint_damping", 0.0)),
                armature=float(hand.get("joint_armature", 0.0)),
                limit_margin=float(hand.get("limit_margin", 0.0)),
                limit_solref=(float(solref[0]), float(solref[1])) if solref else None,
            )
        elif joint.name in names:
            joint = replace(
                joint,
                damping=float(arm.get("joint_damping", 0.0)),
                armature=float(arm.get("joint_armature", 0.0)),
            )
        updated.append(joint)
    transmissions = tuple(Transmission(f"{a.joint}_transmission", a.joint, interface) for a in actuators)
    return replace(robot, joints=tuple(updated), actuators=tuple(actuators), transmissions=transmissions)


def add_keyframes(robot: Robot, keyframes: dict[str, Any], hand_prefix: str, optional: set[str]) -> Robot:
    """Keyframes name hand channels without prefix; ``optional`` joints the variant lacks are left out."""
    channel_names = {c.name for c in robot.channels}
    movable = {j.name for j in robot.joints if j.movable}
    frames = []
    for name, values in keyframes.items():
        positions = {}
        for key, value in (values or {}).items():
            joint = f"{hand_prefix}_{key}" if key in channel_names else key
            if joint in movable:
                if joint not in {c.joint for c in robot.channels} and robot.joint(joint).mimic:
                    raise SvhdescError(
                        f"{where(values, 'keyframes')}: keyframe {name}: {key} is coupled; give its channel instead"
                    )
                positions[joint] = float(value)
            elif key not in optional and key not in channel_names:
                raise SvhdescError(f"{where(values, 'keyframes')}: keyframe {name}: unknown joint {key}")
        full = propagate(robot, positions)
        frames.append(Keyframe(name, tuple((j.name, full[j.name]) for j in robot.joints if j.movable)))
    return replace(robot, keyframes=tuple(frames))


def add_force_sensor(robot: Robot, hand: dict[str, Any], solid_bounds: dict[str, np.ndarray]) -> Robot:
    """Index fingertip force sensing: the site sits at the centre of the tip's collision solid."""
    tip = hand.get("force_sensor")
    if not tip:
        return robot
    link = f"{hand['prefix']}_{tip}"
    if link not in solid_bounds:
        raise SvhdescError(f"force sensor link {link} has no geometry")
    low, high = solid_bounds[link]
    centre = tuple(float(v) for v in (low + high) / 2.0)
    size = float(np.max(high - low)) / 2.0 + 0.002
    return replace(robot, sensors=(ForceSensor(f"{link}_force", link, centre, size),))  # type: ignore[arg-type]


def _speed_ratio(joint: Joint, channel: Channel) -> float:
    """max |d joint / d channel| over the channel's range (1 for the channel itself)."""
    if joint.mimic is None:
        return 1.0
    slope = np.polynomial.polynomial.polyder(np.asarray(joint.mimic.coeffs, dtype=float))
    q = np.linspace(channel.lower, channel.upper, 201)
    return float(np.max(np.abs(np.polynomial.polynomial.polyval(q, slope)))) if len(slope) else 0.0
