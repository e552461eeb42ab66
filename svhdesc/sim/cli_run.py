"""``svhdesc sim VARIANT`` without ROS: run the scene, optionally in the viewer, report the end state."""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from typing import Any

from svhdesc.sim.runtime import Simulation


def run_plain(
    variant: str,
    keyframe: str | None,
    viewer: bool,
    duration: float | None,
    realtime: bool,
    track: Sequence[str],
    echo: Callable[[str], None],
    objects: Sequence[Any] = (),
) -> None:
    from svhdesc.sim.objects import add_objects

    sim = Simulation(variant, keyframe, edit=lambda spec: add_objects(spec, objects))
    for body in track:
        sim.body_pose(body)  # unknown bodies fail before the run
    window = None
    if viewer:
        from svhdesc.sim.viewer import Viewer

        window = Viewer(sim.model, sim.data)
    # Without a viewer a run must end by itself: one simulated second by default.
    length = duration if duration is not None else (math.inf if window else 1.0)

    def on_chunk(_: Simulation) -> bool:
        if window is None:
            return True
        window.sync()
        return window.running

    try:
        factor = sim.run(length, realtime=realtime, callback=on_chunk)
    finally:
        if window is not None:
            window.close()
    echo(f"{variant}: simulated {sim.time:.3f} s at {factor:.1f}x real time")
    state = sim.joint_state()
    for name, position in zip(state.names, state.positions):
        echo(f"  {name:<36} {position:+.5f} rad")
    if sim.touch_body():
        echo(f"  fingertip force ({sim.touch_body()}): {sim.fingertip_force():.4f} N")
    for body in track:
        position, quaternion = sim.body_pose(body)
        echo(
            f"  {body}: xyz {' '.join(f'{v:+.4f}' for v in position)} wxyz {' '.join(f'{v:+.4f}' for v in quaternion)}"
        )
