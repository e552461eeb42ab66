"""Check fingertip_force: each finger pressing a fixed plate at full command gives the driver's tip force.

SCHUNK's driver turns a channel's motor current into a fingertip force (N) with a per-channel line;
at the channel's current limit that is the force the real finger presses with (``tip_force`` in the
coupling spec, sources there). Here each such channel starts at mid-range, the others open, and a
plate is placed just ahead of its fingertip, square to the way the tip moves; the servo is commanded
to its upper limit, so it pushes with its full effort. Gravity is off: the motor alone presses.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from svhdesc.model import HandId
from svhdesc.validate.handsim import (
    TIP_OF_CHANNEL,
    Hand,
    body_vertices,
    channel_jacobian,
    configured_channels,
    find_hand,
    hold_arm,
    set_channels,
)
from svhdesc.validate.options import Options
from svhdesc.validate.pair import ModelPair
from svhdesc.validate.report import Check, not_run, skipped, table, verdict

TOL = 0.20  # relative
GAP = 0.001  # m between fingertip and plate at the start
SETTLE = 0.6  # s pressing
AVERAGE = 0.2  # s at the end over which the force is averaged
PLATE_HALF = (0.012, 0.012, 0.002)  # m


@dataclass(frozen=True)
class Press:
    force: float  # N, normal force of the plate on the finger (mean over the last AVERAGE s)
    lever: float  # m, |d contact point / d channel| at the start pose
    point: np.ndarray  # where the tip meets the plate (world, start pose)
    normal: np.ndarray


def start_pose(hand: Hand, model: Any, channel: str) -> dict[str, float]:
    pose = {name: float(model.jnt_range[j][0]) for name, j in hand.channels.items()}
    low, high = model.jnt_range[hand.channels[channel]]
    pose[channel] = float(low + high) / 2
    return pose


def contact_point(model: Any, data: Any, hand: Hand, channel: str) -> tuple[np.ndarray, np.ndarray, float]:
    """The fingertip's foremost collision vertex along its motion, that motion's direction, its lever."""
    tip = hand.body(model, TIP_OF_CHANNEL[channel])
    vertices = body_vertices(model, data, tip)
    point = data.xipos[tip].copy()
    for _ in range(3):  # the direction depends on the point, the point on the direction
        motion = channel_jacobian(model, data, hand, channel, point, tip)
        direction = motion / np.linalg.norm(motion)
        point = vertices[int(np.argmax(vertices @ direction))]
    motion = channel_jacobian(model, data, hand, channel, point, tip)
    return point, motion / np.linalg.norm(motion), float(np.linalg.norm(motion))


def press(mjcf: Path, channel: str, hand_id: HandId | None) -> Press:
    """``channel``'s fingertip pressed on a wall in the MJCF ``mjcf``, whose hand is ``hand_id`` (the built
    model's)."""
    import mujoco

    base = mujoco.MjModel.from_xml_path(str(mjcf))
    hand = find_hand(base, hand_id)
    if hand is None:
        raise ValueError("no SVH hand (9 channel actuators) in the model")
    data = mujoco.MjData(base)
    pose = start_pose(hand, base, channel)
    hold_arm(base, data, hand)
    set_channels(base, data, hand, pose)
    mujoco.mj_forward(base, data)
    point, normal, lever = contact_point(base, data, hand, channel)

    spec = mujoco.MjSpec.from_file(str(mjcf))
    quat = np.zeros(4)
    mujoco.mju_quatZ2Vec(quat, normal)
    centre = point + normal * (GAP + PLATE_HALF[2])
    # The plate meets the fingertip only (collision bit 2): a neighbouring phalanx grazing its edge
    # would take part of the push, and that is the plate's placing, not the finger.
    spec.worldbody.add_geom(
        name="fingertip_force_plate",
        type=mujoco.mjtGeom.mjGEOM_BOX,
        size=PLATE_HALF,
        pos=centre,
        quat=quat,
        contype=2,
        conaffinity=2,
    )
    tip_name = f"{hand.prefix}_{TIP_OF_CHANNEL[channel]}"
    for geom in spec.body(tip_name).geoms:
        if geom.contype or geom.conaffinity:
            geom.conaffinity |= 2
    model = spec.compile()
    model.opt.gravity[:] = 0.0
    data = mujoco.MjData(model)
    hold_arm(model, data, hand)
    set_channels(model, data, hand, pose)
    data.ctrl[hand.actuators[channel]] = model.actuator_ctrlrange[hand.actuators[channel]][1]
    plate = int(model.geom("fingertip_force_plate").id)
    steps, average = int(round(SETTLE / model.opt.timestep)), int(round(AVERAGE / model.opt.timestep))
    total = 0.0
    wrench = np.zeros(6)
    for step in range(steps):
        mujoco.mj_step(model, data)
        if step < steps - average:
            continue
        for i in range(data.ncon):
            contact = data.contact[i]
            if plate not in (contact.geom1, contact.geom2):
                continue
            mujoco.mj_contactForce(model, data, i, wrench)
            total += wrench[0]
    return Press(total / average, lever, point, normal)


def check_fingertip_force(pair: ModelPair, options: Options) -> list[Check]:
    bound = f"within {TOL:.0%} of the driver's tip force"
    if pair.model is None:
        return [not_run("fingertip_force", "the MJCF does not compile", bound)]
    if find_hand(pair.model, pair.hand) is None:
        return [skipped("fingertip_force", "no SVH hand", bound)]
    channels = configured_channels(pair)
    if channels is None:
        return [not_run("fingertip_force", "not a configured variant: no driver forces to compare with", bound)]
    rows, problems, figures, worst = [], [], {}, 0.0
    for name, channel in channels.items():
        if channel.tip_force is None or name not in TIP_OF_CHANNEL:
            continue
        result = press(pair.mjcf_path, name, pair.hand)
        error = result.force / channel.tip_force - 1.0
        worst = max(worst, abs(error))
        figures[name] = {
            "tip_force_N": result.force,
            "driver_N": channel.tip_force,
            "effort_Nm": channel.effort,
            "lever_m": result.lever,
        }
        rows.append(
            [
                name,
                f"{channel.tip_force:.2f}",
                f"{channel.effort:.3f}",
                f"{result.lever * 1000:.1f}",
                f"{result.force:.2f}",
                f"{error:+.1%}",
            ]
        )
        if abs(error) > TOL:
            problems.append(f"{name} presses {result.force:.3g} N, driver {channel.tip_force:.3g} N ({error:+.0%})")
    if not rows:
        return [skipped("fingertip_force", "the coupling spec gives no tip_force", bound)]
    header = ["channel", "driver N", "effort N m", "lever mm", "simulated N", "error"]
    return [
        Check(
            "fingertip_force",
            verdict(not problems),
            f"worst {worst:.1%}",
            bound,
            "; ".join(problems) or f"{len(rows)} channels, plate ahead of each fingertip, gravity off",
            figures,
            table=table(rows, header),
        )
    ]


__all__ = ["check_fingertip_force", "press"]
