"""Actuators, transmissions, joint dynamics, keyframes and the fingertip force sensor."""

from __future__ import annotations

import warnings
from dataclasses import replace
from typing import Any

import numpy as np

from svhdesc.compiler.assets import Assets
from svhdesc.compiler.stages.inertials import link_solid
from svhdesc.core.settings.coupling import propagate
from svhdesc.core.settings.schema import Arm, Hand, Transmissions
from svhdesc.core.settings.yamlio import where
from svhdesc.errors import SvhdescError
from svhdesc.ir import Actuator, Channel, ForceSensor, Joint, Keyframe, Robot, Transmission

INTERFACES = {
    "position": "hardware_interface/PositionJointInterface",
    "effort": "hardware_interface/EffortJointInterface",
}
VELOCITY_INTERFACE = "hardware_interface/VelocityJointInterface"  # a velocity servo's, whatever the section says
# A velocity servo exerts its full effort this far (a share of the rated velocity) off its commanded velocity: kv =
# effort / (VELOCITY_ERROR x velocity), as a position servo's kp = effort / 0.1 rad.
VELOCITY_ERROR = 0.1


def arm_joints(robot: Robot, arm: Arm) -> list[str]:
    if not arm.active:
        return []
    names = {j.name for j in robot.joints}
    missing = [j for j in arm.joints if j not in names]
    if missing:
        raise SvhdescError(f"{arm.at('joints')}: arm.joints: not in the robot: {missing}")
    return list(arm.joints)


class FrictionWarning(UserWarning):
    """A source's joint friction was capped so that the joint's drive can beat it."""


def _damping(joint: Joint, section: Hand | Arm, key: str) -> float:
    """The section's damping where the config writes it, else the source's <dynamics damping>."""
    return float(getattr(section, key)) if key in section.lines else joint.damping


def _joint_dynamics(joint: Joint, overrides: dict[str, Any], friction_cap: float) -> Joint:
    """joints.NAME's damping and friction over everything; else the source's friction, capped at
    ``friction_cap`` x effort (a weak drive must beat it), with one warning naming the joint."""
    given = overrides.get(joint.name)
    damping = given.damping if given is not None and given.damping is not None else joint.damping
    if given is not None and given.friction is not None:
        return replace(joint, damping=damping, friction=given.friction)
    friction, cap = joint.friction, friction_cap * joint.effort
    if joint.effort > 0 and friction > cap:
        warnings.warn(
            f"joint {joint.name}: source friction {friction:g} capped at {cap:g} ({friction_cap:g} x its effort "
            f"{joint.effort:g}) so that its drive can beat it; set joints.{joint.name}.friction to keep it",
            FrictionWarning,
            stacklevel=3,
        )
        friction = cap
    return replace(joint, damping=damping, friction=friction)


def _check_joint_names(robot: Robot, overrides: dict[str, Any]) -> None:
    names = {j.name for j in robot.joints}
    for name, quirk in overrides.items():
        if name not in names and getattr(quirk, "rename", None) is None:  # a renamed joint goes by its new name
            at = getattr(overrides, "lines", {}).get(name, "config")
            raise SvhdescError(f"{at}: joints.{name}: no joint {name!r} in robot {robot.name}")


def add_actuation(
    robot: Robot, assets: Assets, section: tuple[Hand, Arm, Transmissions, dict[str, Any], float]
) -> Robot:
    """Channels and arm joints become position actuators with ros_control transmissions."""
    hand, arm, transmissions, overrides, friction_cap = section
    _check_joint_names(robot, overrides)
    interface = INTERFACES[transmissions.interface]
    joints = {j.name: j for j in robot.joints}
    channel_of = {c.joint: c for c in robot.channels}
    followers = {j.name: j.mimic.joint for j in robot.joints if j.mimic}
    actuators = [
        Actuator(c.joint, c.joint, c.lower, c.upper, c.effort, hand.kp, hand.dampratio) for c in robot.channels
    ]
    names = arm_joints(robot, arm)
    kps = arm.kp if isinstance(arm.kp, list) else [arm.kp] * len(names)
    if names and len(kps) != len(names):
        raise SvhdescError(f"{arm.at('kp')}: arm.kp: expected {len(names)} values (one per arm joint), got {len(kps)}")
    for name, kp in zip(names, kps):
        actuators.append(_arm_servo(joints[name], kp, arm, overrides.get(name)))
    _check_servo_keys(overrides, {a.joint for a in actuators if a.velocity}, set(names))
    # Joint dynamics: channel efforts/velocities come from the spec; followers share their channel's
    # effort, and move as fast as the coupling makes them (j4 turns 1.45x as fast as Thumb_Flexion):
    # a follower capped at the channel's speed lags behind it in engines that enforce velocity limits.
    updated = []
    for joint in robot.joints:
        if joint.name in channel_of or joint.name in followers:
            channel = channel_of[followers.get(joint.name, joint.name)]
            joint = replace(
                joint,
                effort=channel.effort,
                velocity=channel.velocity * _speed_ratio(joint, channel),
                # The drive's friction and reflected inertia sit at the motor, i.e. the channel joint.
                damping=_damping(joint, hand, "joint_damping" if joint.name in channel_of else "coupled_joint_damping"),
                armature=hand.joint_armature if joint.name in channel_of else hand.coupled_joint_armature,
                limit_margin=hand.limit_margin,
                limit_solref=_solref(hand.limit_solref),
            )
        elif joint.name in names:
            joint = replace(
                joint,
                damping=_damping(joint, arm, "joint_damping"),
                armature=arm.joint_armature,
                limit_margin=arm.limit_margin,
                limit_solref=_solref(arm.limit_solref),
            )
        updated.append(_joint_dynamics(joint, overrides, friction_cap) if joint.movable else joint)
    transmissions_ = tuple(
        Transmission(f"{a.joint}_transmission", a.joint, VELOCITY_INTERFACE if a.velocity else interface)
        for a in actuators
    )
    return replace(robot, joints=tuple(updated), actuators=tuple(actuators), transmissions=transmissions_)


def _arm_servo(joint: Joint, kp: float, arm: Arm, quirk: Any) -> Actuator:
    """A position servo; a continuous joint (a wheel, an endless wrist) gets one without limits (any angle is a
    target), or, with joints.NAME.servo: velocity, a velocity servo over its rated velocity."""
    continuous = joint.type == "continuous"
    if continuous and getattr(quirk, "servo", None) == "velocity":
        kv = joint.effort / (VELOCITY_ERROR * joint.velocity)
        v = joint.velocity
        return Actuator(joint.name, joint.name, -v, v, joint.effort, kv, arm.dampratio, True, "velocity")
    return Actuator(joint.name, joint.name, joint.lower, joint.upper, joint.effort, kp, arm.dampratio, not continuous)


def _check_servo_keys(overrides: dict[str, Any], velocity: set[str], arm: set[str]) -> None:
    """joints.NAME.servo: velocity is for a continuous arm joint (a channel, a limited joint: a position servo)."""
    for name, quirk in overrides.items():
        if getattr(quirk, "servo", None) == "velocity" and name not in velocity:
            why = "is not in arm.joints" if name not in arm else "is not continuous (it has limits)"
            raise SvhdescError(
                f"{quirk.at('servo')}: joints.{name}.servo: velocity is for a continuous joint of the arm, and "
                f"{name} {why}"
            )


def _solref(values: list[float] | None) -> tuple[float, float] | None:
    return (values[0], values[1]) if values else None


def add_keyframes(robot: Robot, assets: Assets, section: tuple[dict[str, Any], Hand, Arm]) -> Robot:
    """Keyframes name hand channels by channel name (a joint's own name otherwise); arm joints the variant
    lacks are left out."""
    keyframes, hand, arm = section
    optional = set(arm.joints)
    channel_joint = {c.name: c.joint for c in robot.channels}
    channel_names = set(channel_joint)
    movable = {j.name for j in robot.joints if j.movable}
    frames = []
    for name, values in keyframes.items():
        positions = {}
        for key, value in (values or {}).items():
            joint = channel_joint.get(key, key)
            if joint not in movable and hand.prefix and f"{hand.prefix}_{key}" in movable:
                joint = f"{hand.prefix}_{key}"  # a hand joint by its spec name (j2 for right_hand_j2)
            if joint in movable:
                if joint not in {c.joint for c in robot.channels} and robot.joint(joint).mimic:
                    at = where(values, "keyframes", key)
                    raise SvhdescError(f"{at}: keyframe {name}: {key} is a coupled joint; give its channel instead")
                positions[joint] = float(value)
            elif key not in optional and key not in channel_names:
                raise SvhdescError(f"{where(values, 'keyframes', key)}: keyframe {name}: unknown joint {key}")
        full = propagate(robot, positions)
        frames.append(Keyframe(name, tuple((j.name, full[j.name]) for j in robot.joints if j.movable)))
    return replace(robot, keyframes=tuple(frames))


def add_force_sensor(robot: Robot, assets: Assets, hand: Hand) -> Robot:
    """Index fingertip force sensing: the site sits at the centre of the tip's collision solid."""
    if not hand.force_sensor:
        return robot
    link = hand.link(hand.force_sensor)
    tip = next((candidate for candidate in robot.links if candidate.name == link), None)
    if tip is None:
        return robot  # a missing link is the name check's to report (check_hand_names, after the processors)
    if not tip.collisions:
        raise SvhdescError(f"{hand.at('force_sensor')}: hand.force_sensor: link {link} has no geometry")
    low, high = np.array(link_solid(tip, assets).bounds)
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
