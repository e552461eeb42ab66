"""Each channel's effort from the SCHUNK driver's fingertip force (issue 15), and what the model presses with.

For every channel with a driver tip force (config/coupling.yaml, sources there): the lever
|d tip / d channel| at the fingertip's foremost point (channel at mid-range, the others open, coupled
joints following), the effort that force needs there (F x lever, what the config should carry), the
config's effort, and the force the built model presses a plate with at full command. Then each channel's
top speed unloaded (gravity off, commanded from its lower to its upper end), beside the driver's velocity
limit: the drives' damping (set for validate's load_limits) caps it.

    python benchmarks/driver_limits.py [VARIANT]
"""

from __future__ import annotations

import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]


def main(variant: str = "svh_right") -> int:
    from svhdesc.core.settings.coupling import load_spec
    from svhdesc.model import get
    from svhdesc.validate.fingertip_force import press

    mjcf = REPO / "generated" / variant / f"{variant}.xml"
    spec = load_spec(REPO / "config" / "coupling.yaml")
    print(f"{'channel':24} {'driver N':>8} {'lever mm':>8} {'F x lever':>9} {'config N m':>10} {'pressed N':>9}")
    for channel in spec.channels:
        if channel.tip_force is None:
            print(f"{channel.name:24} {'-':>8} {'-':>8} {'-':>9} {channel.effort:10.3f} {'-':>9}")
            continue
        result = press(mjcf, channel.name, get(variant).hand)
        derived = channel.tip_force * result.lever
        print(
            f"{channel.name:24} {channel.tip_force:8.3f} {result.lever * 1000:8.1f} {derived:9.4f} "
            f"{channel.effort:10.3f} {result.force:9.3f}"
        )
    print(f"\n{'channel':24} {'driver rad/s':>12} {'model rad/s':>11}")
    for channel in spec.channels:
        print(f"{channel.name:24} {channel.velocity:12.3f} {top_speed(mjcf, channel.name):11.3f}")
    return 0


def top_speed(mjcf: Path, channel: str, duration: float = 3.0) -> float:
    import mujoco
    import numpy as np

    from svhdesc.model import get
    from svhdesc.validate.handsim import find_hand, set_channels

    model = mujoco.MjModel.from_xml_path(str(mjcf))
    model.opt.gravity[:] = 0.0
    data = mujoco.MjData(model)
    hand = find_hand(model, get(mjcf.stem).hand)
    assert hand is not None
    set_channels(model, data, hand, {name: float(model.jnt_range[j][0]) for name, j in hand.channels.items()})
    joint = hand.channels[channel]
    data.ctrl[hand.actuators[channel]] = model.jnt_range[joint][1]
    fastest = 0.0
    for _ in range(int(duration / model.opt.timestep)):
        mujoco.mj_step(model, data)
        fastest = max(fastest, float(np.abs(data.qvel[model.jnt_dofadr[joint]])))
    return fastest


if __name__ == "__main__":
    sys.exit(main(*sys.argv[1:2]))
