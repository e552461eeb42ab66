"""Keyframe poses the hand can be in: a keyframe whose fingers close into each other stops where they meet.

A keyframe is a state a user loads (``mj_resetDataKeyframe``, MoveIt's ``group_state``, mjlab's initial state), so its
pose must be physically valid: no two bodies interpenetrating. A grasp's configured channels close past its object
so that the servos press it with their full effort; without the object the fingers close into each other (the SVH's
``power`` and ``lateral`` by 5 to 14 mm). So the configured values stay the keyframe's servo targets (the MJCF key's
``ctrl``, ``Keyframe.targets``), and the pose (its ``qpos``, the SRDF's group state) becomes where the fingers stop.

The stop is found by geometry, not by stepping the servos: a simulated rest moves by 1e-4 rad when the inputs move
by a few ulps (another CPU), and the build writes the same bytes on any CPU. From ``home``, every channel closes
towards its target in STEPS equal steps, all together, one channel after the other within a step; a channel whose
next step would put two bodies that may collide deeper than TOLERANCE into each other stops where it is, the others
go on. The coupled joints follow the channels through the spec (as ``add_keyframes`` propagates them), the arm's
joints keep their configured values. A keyframe within TOLERANCE, a robot without channels, and a keyframe deeper
than TOLERANCE already with its hand at ``home`` (the arm's pose, not the fingers) keep their configured pose. The
result is remembered by content in the probes' cache, as ``trial_run`` is.
"""

from __future__ import annotations

import inspect
from dataclasses import replace
from pathlib import Path
from typing import Any

from svhdesc.compiler.assets import Assets
from svhdesc.compiler.export.mjcf import export_mjcf
from svhdesc.compiler.probes.cache import cache_dir, content_key, remembered
from svhdesc.core.settings.coupling import propagate
from svhdesc.ir import Keyframe, Robot

TOLERANCE = 0.001  # m: the deepest contact a keyframe's pose may have
STEPS = 200  # each channel's way from home to its target, in this many steps
ROUNDING = 4  # decimals of a channel stopped on its way (1e-4 rad)


def deepest(model: Any, data: Any) -> float:
    """The deepest contact (m, 0 for none) of the pose in ``data``'s qpos, between bodies that may collide."""
    import mujoco

    mujoco.mj_kinematics(model, data)
    mujoco.mj_collision(model, data)
    return max([0.0, *(-float(c.dist) for c in data.contact[: data.ncon])])


class _Pose:
    """A keyframe's pose in MuJoCo: its configured joints, the channels set, the coupled joints following."""

    def __init__(self, model: Any, robot: Robot, frame: Keyframe) -> None:
        import mujoco

        self.model, self.robot, self.data = model, robot, mujoco.MjData(model)
        self.configured = dict(frame.qpos)
        self.address = {j: int(model.jnt_qposadr[model.joint(j).id]) for j in self.configured}

    def depth(self, channels: dict[str, float]) -> float:
        for joint, value in propagate(self.robot, {**self.configured, **channels}).items():
            self.data.qpos[self.address[joint]] = value
        return deepest(self.model, self.data)


def _step(start: float, end: float, step: int) -> float:
    return end if step == STEPS else round(start + step * (end - start) / STEPS, ROUNDING)


def close_until_contact(pose: _Pose, home: dict[str, float], targets: dict[str, float]) -> dict[str, float]:
    """The channels closed from ``home`` towards ``targets`` until each meets something (see the module's text)."""
    channels = dict(home)
    moving = [j for j in channels if targets[j] != home[j]]
    for step in range(1, STEPS + 1):
        for joint in list(moving):
            before = channels[joint]
            channels[joint] = _step(home[joint], targets[joint], step)
            if pose.depth(channels) > TOLERANCE:
                channels[joint] = before
                moving.remove(joint)
    return channels


def stopped_poses(robot: Robot, assets: Assets, mjcf: bytes) -> dict[str, dict[str, float]]:
    """Keyframe name -> its channels where the fingers stop, for each keyframe deeper than TOLERANCE whose hand at
    ``home`` is within it."""
    import mujoco

    files = {f"assets/{name}": data for name, data in assets.files.items()}
    model = mujoco.MjModel.from_xml_string(mjcf.decode(), files)
    frames = {k.name: k for k in robot.keyframes}
    at_home = dict(frames["home"].qpos) if "home" in frames else propagate(robot, {})
    home = {c.joint: at_home[c.joint] for c in robot.channels}
    found = {}
    for frame in robot.keyframes:
        pose, targets = _Pose(model, robot, frame), frame.servo_targets()
        channels = {j: targets[j] for j in home}
        if pose.depth(channels) <= TOLERANCE or pose.depth(home) > TOLERANCE:
            continue
        found[frame.name] = close_until_contact(pose, home, channels)
    return found


def _remembered(robot: Robot, assets: Assets) -> dict[str, dict[str, float]]:
    """``stopped_poses``, remembered by content: the MJCF states the model and its keyframes, the code the rest."""
    mjcf = export_mjcf(robot)
    code = Path(__file__).read_bytes() + inspect.getsource(propagate).encode()
    key = content_key((code, mjcf), assets.files)

    def encode(found: dict[str, dict[str, float]]) -> Any:  # [] for none: the cache reads a null value as no entry
        return [[name, sorted(channels.items())] for name, channels in sorted(found.items())]

    def decode(entry: Any) -> dict[str, dict[str, float]]:
        return {str(name): {str(j): float(q) for j, q in channels} for name, channels in entry}

    return remembered(cache_dir("keyframe_poses"), key, lambda: stopped_poses(robot, assets, mjcf), encode, decode)


def stop_at_contact(robot: Robot, assets: Assets, section: Any = None) -> Robot:
    """The keyframe processor: each keyframe whose fingers interpenetrate gets the pose where they stop, its
    configured positions kept as its servo targets."""
    if not robot.channels or not robot.keyframes:
        return robot
    stopped = _remembered(robot, assets)
    if not stopped:
        return robot
    actuated = {a.joint for a in robot.actuators}
    frames = []
    for frame in robot.keyframes:
        if frame.name in stopped:
            full = propagate(robot, {**dict(frame.qpos), **stopped[frame.name]})
            pose = tuple((j, full[j]) for j, _ in frame.qpos)
            targets = tuple((j, q) for j, q in frame.servo_targets().items() if j in actuated)
            frame = replace(frame, qpos=pose, targets=targets)
        frames.append(frame)
    return replace(robot, keyframes=tuple(frames))
