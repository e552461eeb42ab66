"""Each channel's effort from the SCHUNK driver's fingertip force (issue 15), and what the model presses with.

For every channel with a driver tip force (config/coupling.yaml, sources there): the lever
|d tip / d channel| at the fingertip's foremost point (channel at mid-range, the others open, coupled
joints following), the effort that force needs there (F x lever, what the config should carry), the
config's effort, and the force the built model presses a plate with at full command.

    python benchmarks/driver_limits.py [VARIANT]
"""

from __future__ import annotations

import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]


def main(variant: str = "svh_right") -> int:
    from svhdesc.coupling import load_spec
    from svhdesc.validate.fingertip_force import press

    mjcf = REPO / "generated" / variant / f"{variant}.xml"
    spec = load_spec(REPO / "config" / "coupling.yaml")
    print(f"{'channel':24} {'driver N':>8} {'lever mm':>8} {'F x lever':>9} {'config N m':>10} {'pressed N':>9}")
    for channel in spec.channels:
        if channel.tip_force is None:
            print(f"{channel.name:24} {'-':>8} {'-':>8} {'-':>9} {channel.effort:10.3f} {'-':>9}")
            continue
        result = press(mjcf, channel.name)
        derived = channel.tip_force * result.lever
        print(
            f"{channel.name:24} {channel.tip_force:8.3f} {result.lever * 1000:8.1f} {derived:9.4f} "
            f"{channel.effort:10.3f} {result.force:9.3f}"
        )
    return 0


if __name__ == "__main__":
    sys.exit(main(*sys.argv[1:2]))
