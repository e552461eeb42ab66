"""Scripted actors a trained policy is measured against: a finger gait played open loop."""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np


class Gait:
    """Action ``amplitude * sin(2 pi frequency t + k * phase)`` on the ``k``-th of ``channels`` (indices into the
    action), 0 on the others; ``t`` counts control periods of ``1/control_hz`` from the first call, across
    episodes (a baseline has no notion of them)."""

    def __init__(
        self, width: int, control_hz: float, channels: Sequence[int], amplitude: float, frequency: float, phase: float
    ) -> None:
        self.width, self.dt = width, 1.0 / control_hz
        self.channels, self.amplitude, self.frequency, self.phase = list(channels), amplitude, frequency, phase
        self.step = 0

    def __call__(self, obs: np.ndarray) -> np.ndarray:
        t = self.step * self.dt
        self.step += 1
        action = np.zeros((obs.shape[0], self.width), dtype=np.float32)
        for k, channel in enumerate(self.channels):
            action[:, channel] = self.amplitude * math.sin(2 * math.pi * self.frequency * t + k * self.phase)
        return action


# The scripted gait for svh_rotate: thumb opposition, index finger and thumb flexion in a travelling wave. The best
# of 32 open-loop gaits tried (thumb, thumb and index, all channels, the four fingers; amplitude 0.6 or 1; 0.5 or
# 1 Hz; phase step +-pi/2) on 8 episodes each in MuJoCo C.
ROTATE_GAIT = {
    "channels": ("Thumb_Opposition", "Index_Finger_Proximal", "Thumb_Flexion"),
    "amplitude": 1.0,
    "frequency": 0.5,
    "phase": -math.pi / 2,
}
SCRIPTED = {"svh_rotate": ROTATE_GAIT}


def scripted(env: object) -> Gait | None:
    """The task's scripted baseline (None where it has none), for ``env``'s actions."""
    spec = SCRIPTED.get(env.task.name)  # type: ignore[attr-defined]
    if spec is None:
        return None
    names = [env.channel_name(a) for a in env.actuators]  # type: ignore[attr-defined]
    channels = [names.index(c) for c in spec["channels"]]
    return Gait(env.num_actions, env.task.control_hz, channels, spec["amplitude"], spec["frequency"], spec["phase"])  # type: ignore[attr-defined]
