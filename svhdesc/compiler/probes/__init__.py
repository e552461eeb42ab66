"""The probes: what a build learns by compiling the model in MuJoCo and sampling it, which no processor of the IR
can say and no exporter may compute.

- ``rest_contacts``: the link pairs touching at rest; the pipeline runs it as the last processor (its result is the
  IR's contact exclusions);
- ``stability``: whether the timestep integrates the model's servos; the pipeline refuses a model it would not;
- ``damping``, ``collision_matrix``, ``batch_capacities``: run by the pipeline on the finished model, once its
  assets are written, for the outputs that name them (``export/registry.py``: ``Output.probes``); their results
  reach the exporters as ``Probed``;
- ``cache``: the sampled results remembered by content, beside the hulls.

Probes read the IR and the exporters' MJCF; no stage or exporter imports a probe.
"""

from __future__ import annotations

from collections.abc import Callable, Collection
from pathlib import Path
from typing import Any

from svhdesc.compiler.assets import Assets
from svhdesc.compiler.export import batch
from svhdesc.compiler.export.registry import PROBES, Probed
from svhdesc.compiler.probes.batch_capacities import cached_capacities
from svhdesc.compiler.probes.collision_matrix import cached_collision_matrix
from svhdesc.compiler.probes.damping import servo_damping
from svhdesc.ir import Robot
from svhdesc.model import batch_model_file


def _capacities(robot: Robot, assets: Assets, assets_dir: Path) -> batch.Capacities:
    """The batch model's capacities, sized by stepping the unsized model in MuJoCo C."""
    scene = batch.export_batch_scene(robot)
    unsized = batch.export_batch(robot, None)
    return cached_capacities(scene, batch_model_file(robot.name), unsized, assets_dir)


RUN: dict[str, Callable[[Robot, Assets, Path], Any]] = {
    "damping": lambda robot, assets, _: servo_damping(robot, assets),
    "collision_matrix": lambda robot, assets, _: cached_collision_matrix(robot, assets),
    "capacities": _capacities,
}


def probe(robot: Robot, assets: Assets, assets_dir: Path, wanted: Collection[str]) -> Probed:
    """The results ``wanted`` (names in ``PROBES``) for ``robot``, its assets written under ``assets_dir``."""
    return Probed({name: RUN[name](robot, assets, assets_dir) for name in PROBES if name in wanted})
