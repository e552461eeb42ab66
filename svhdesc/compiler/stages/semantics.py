"""Checks across sections that no single value check can make: names that must exist, keyframes
inside the limits, and every movable joint driven (a channel, a coupled joint or an actuated arm joint)."""

from __future__ import annotations

from typing import Any

from svhdesc.core.settings.schema import Arm, Hand
from svhdesc.core.settings.yamlio import where
from svhdesc.errors import SvhdescError
from svhdesc.ir import Robot

LIMIT_TOL = 1e-9


def check_hand_names(robot: Robot, hand: Hand) -> None:
    links = {link.name for link in robot.links}
    for tip in hand.fingertips:
        if hand.link(tip) not in links:
            raise SvhdescError(f"{hand.at('fingertips')}: hand.fingertips: no link {hand.link(tip)}")
    tip = hand.force_sensor
    if tip and hand.link(tip) not in links:
        raise SvhdescError(f"{hand.at('force_sensor')}: hand.force_sensor: no link {hand.link(tip)}")


def check_unique_names(robot: Robot, section: tuple[Hand, Arm]) -> None:
    """One name per element of a kind in the final model: MuJoCo refuses a repeat, URDF tools pick one silently.

    Links and joints are checked where the xacro is read; here also whatever the stages added.
    """
    hand, arm = section
    joints = [j.name for j in robot.joints]
    kinds = (
        ("link", [link.name for link in robot.links], lambda i: robot.name),
        ("joint", joints, lambda i: robot.joints[i].source or robot.name),
        # Actuators: one per channel and one per arm.joints entry; a repeat comes from arm.joints.
        ("actuator", [a.name for a in robot.actuators], lambda i: arm.at("joints")),
        ("transmission", [t.name for t in robot.transmissions], lambda i: arm.at("joints")),
        # The force sensor's touch sensor reads a site of its own name.
        ("site", [s.name for s in robot.sensors], lambda i: hand.at("force_sensor")),
        ("sensor", [s.name for s in robot.sensors], lambda i: hand.at("force_sensor")),
        ("keyframe", [k.name for k in robot.keyframes], lambda i: robot.name),
    )
    for kind, names, located in kinds:
        seen: set[str] = set()
        for index, name in enumerate(names):
            if name in seen:
                raise SvhdescError(f"{located(index)}: duplicate {kind} name '{name}' in the model")
            seen.add(name)


def check_driven(robot: Robot, arm: Arm) -> None:
    """An undriven joint swings free in simulation: refuse it, naming the key that would drive it, and actuators
    that cannot move."""
    channels = {c.joint for c in robot.channels}
    actuated = {a.joint: a for a in robot.actuators}
    for joint in robot.joints:
        if joint.movable and joint.name not in channels and joint.mimic is None and joint.name not in actuated:
            raise SvhdescError(
                f"{joint.source}: is neither a channel, a coupled joint nor an actuated arm joint: nothing drives it "
                f"({_way_out(joint.name, arm)})"
            )
    for actuator in robot.actuators:
        joint = robot.joint(actuator.joint)
        if actuator.effort <= 0 or joint.velocity <= 0:
            raise SvhdescError(
                f"{joint.source}: an actuated joint needs effort > 0 and velocity > 0 "
                f"(has {actuator.effort:g} and {joint.velocity:g})"
            )
        if actuator.limited and actuator.lower >= actuator.upper:
            raise SvhdescError(f"{joint.source}: an actuated joint needs lower < upper")


def _way_out(joint: str, arm: Arm) -> str:
    if joint in arm.joints and not arm.active:
        return f"it is in arm.joints, but arm.enabled is false at {arm.at('enabled')}: set it true"
    return "list it in arm.joints (one servo each, gain arm.kp), or make it a channel or coupled joint in the spec"


def check_keyframes(robot: Robot, section: tuple[dict[str, Any], str]) -> None:
    """Every keyframe inside the joint limits; ``section``: the keyframes and where the settings were written."""
    keyframes, at = section
    joints = {j.name: j for j in robot.joints}
    for frame in robot.keyframes:
        for name, value in frame.qpos:
            joint = joints[name]
            if joint.type == "continuous":
                continue
            if not joint.lower - LIMIT_TOL <= value <= joint.upper + LIMIT_TOL:
                raise SvhdescError(
                    f"{where(keyframes, at, frame.name)}: keyframe {frame.name} puts {name} at {value:.6g}, "
                    f"outside its limit [{joint.lower:g}, {joint.upper:g}]"
                )
