"""The touching-at-rest probe: compile the model in MuJoCo and list the link pairs in contact at q = 0.

The pipeline runs it as its last processor (``exclude_touching``): its result becomes the IR's exclusions through
the stage ``excludes``, which takes the probe as an argument and so imports no exporter.
"""

from __future__ import annotations

from typing import Any

from svhdesc.compiler.assets import Assets
from svhdesc.compiler.export.mjcf import export_mjcf
from svhdesc.compiler.stages.excludes import add_excludes, configured_excludes
from svhdesc.errors import SvhdescError
from svhdesc.ir import Robot


def touching_at_rest(robot: Robot, assets: Assets) -> set[tuple[str, str]]:
    import mujoco

    xml = export_mjcf(robot).decode()
    try:
        model = mujoco.MjModel.from_xml_string(xml, {f"assets/{k}": v for k, v in assets.files.items()})
    except ValueError as exc:  # MuJoCo's compiler names the element; the IR checks should catch it first
        raise SvhdescError(f"{robot.name}: MuJoCo refuses the model: {str(exc).splitlines()[0]}") from None
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    pairs = set()
    for contact in data.contact[: data.ncon]:
        bodies = [model.body(model.geom_bodyid[g]).name for g in (contact.geom1, contact.geom2)]
        pairs.add((bodies[0], bodies[1]))
    return pairs


def exclude_touching(robot: Robot, assets: Assets, section: dict[str, Any] | None = None) -> Robot:
    """The exclusions processor: adjacent pairs, ``collision.exclude``, and the pairs this probe finds
    touching at rest."""
    extra = configured_excludes(robot, section) if section is not None else set()
    return add_excludes(robot, lambda r: touching_at_rest(r, assets), extra)
