"""The built models as mjlab entities: ``EntityCfg(spec_fn=...)`` over a variant's batch MJCF (the model svhdesc
builds for MuJoCo Warp), read through svhdesc's contract (``svhdesc.model``). Nothing is restated here:

- the actuators are the MJCF's own ``<position>`` servos, wrapped as they are (``XmlActuatorCfg``): the hand's 9
  driver channels, the UR's 6; their gains, force and control ranges stay the built model's;
- the couplings stay the MJCF's joint equalities (11 on an SVH), as mjlab's YAM keeps its second finger;
- the initial state is a keyframe of the model (``home`` unless a task asks for another pose);
- collisions stay as built (contype, conaffinity, condim of each geom: no ``CollisionCfg`` edits them);
- the action scale of each actuator is a fixed fraction of its control range's width.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path
from typing import Any

import mujoco

from svhdesc.errors import SvhdescError
from svhdesc.model import Coupling, HandId, Model, actuated_joints, couplings, get

ACTION_SPAN = 0.25  # an action of +-1 moves a servo's target this fraction of its control range from the default


@dataclass(frozen=True)
class Built:
    """What an entity takes from one built variant (read once per process and variant)."""

    model: Model
    hand: HandId | None
    joints: tuple[str, ...]  # scalar joints, model order
    ranges: dict[str, tuple[float, float]]  # actuated joint -> the actuator's control range
    couplings: tuple[Coupling, ...]
    keyframes: dict[str, dict[str, float]]  # keyframe name -> joint -> position
    options: dict[str, Any]  # the batch model's solver options, in mjlab's MujocoCfg terms


def built(variant: str | Path) -> Built:
    """The variant's facts, or an SvhdescError naming what is wrong (unknown variant, no batch model)."""
    try:
        model = get(variant)
    except KeyError as exc:
        raise SvhdescError(str(exc.args[0])) from None
    return _read(model)


@lru_cache(maxsize=8)
def _read(model: Model) -> Built:
    if not model.batch_path.is_file():
        raise SvhdescError(f"{model.batch_path}: no batch model (rebuild: svhdesc build {model.name})")
    compiled = mujoco.MjModel.from_xml_path(str(model.batch_path))
    joints = tuple(compiled.joint(j).name for j in range(compiled.njnt))
    keyframes = {}
    for k in range(compiled.nkey):
        qpos = compiled.key_qpos[k]
        keyframes[compiled.key(k).name] = {
            compiled.joint(j).name: float(qpos[compiled.jnt_qposadr[j]]) for j in range(compiled.njnt)
        }
    ranges, coupled = actuated_joints(compiled), tuple(couplings(compiled))
    return Built(model, model.hand, joints, ranges, coupled, keyframes, _options(compiled.opt))


def _options(opt: Any) -> dict[str, Any]:
    """The model's <option> as mjlab's ``MujocoCfg`` fields (mjlab sets them on the scene's model)."""
    names = {
        "integrator": {
            int(mujoco.mjtIntegrator.mjINT_EULER): "euler",
            int(mujoco.mjtIntegrator.mjINT_IMPLICITFAST): "implicitfast",
        },
        "cone": {int(mujoco.mjtCone.mjCONE_PYRAMIDAL): "pyramidal", int(mujoco.mjtCone.mjCONE_ELLIPTIC): "elliptic"},
        "solver": {
            int(mujoco.mjtSolver.mjSOL_NEWTON): "newton",
            int(mujoco.mjtSolver.mjSOL_CG): "cg",
            int(mujoco.mjtSolver.mjSOL_PGS): "pgs",
        },
    }
    options = {key: table[int(getattr(opt, key))] for key, table in names.items()}
    for key in ("timestep", "impratio", "tolerance", "iterations", "ls_iterations", "ls_tolerance", "ccd_iterations"):
        value = getattr(opt, key)
        options[key] = int(value) if key.endswith("iterations") else float(value)
    return options


def mujoco_cfg(facts: Built, timestep: float | None = None) -> Any:
    """mjlab's ``MujocoCfg`` of the variant's batch model (its solver, cone, integrator, tolerances), at
    ``timestep`` where a task steps otherwise."""
    from mjlab.sim import MujocoCfg

    options = dict(facts.options)
    if timestep is not None:
        options["timestep"] = timestep
    return MujocoCfg(**options)


Site = tuple[str, str, tuple[float, float, float]]  # body, site name, position in the body's frame


def spec_fn(model: Model, sites: tuple[Site, ...] = ()) -> Any:
    """A function giving the variant's batch MJCF as an ``MjSpec``, what ``EntityCfg.spec_fn`` takes: its keyframes
    left out (the entity writes its own initial state from one of them), ``sites`` added (a task's points)."""

    def load() -> mujoco.MjSpec:
        spec = mujoco.MjSpec.from_file(str(model.batch_path))
        for key in list(spec.keys):
            spec.delete(key)
        # The scene's options are mjlab's (``mujoco_cfg`` carries this model's): the entity's own are left at
        # MuJoCo's defaults, so that attaching it reports no conflict.
        blank = mujoco.MjSpec()
        for name in ("timestep", "tolerance", "impratio", "integrator", "cone"):
            setattr(spec.option, name, getattr(blank.option, name))
        spec.njmax, spec.nconmax = blank.njmax, blank.nconmax
        for body, name, pos in sites:
            spec.body(body).add_site(name=name, pos=pos)
        return spec

    return load


def pose(facts: Built, channels: dict[str, float] | None = None, keyframe: str = "home") -> dict[str, float]:
    """Every joint's position: the keyframe's, with ``channels`` (actuated joints by name, or a hand's driver
    channel by its unprefixed name) set and each coupled joint put where its coupling says."""
    positions = dict(facts.keyframes[keyframe]) if keyframe in facts.keyframes else dict.fromkeys(facts.joints, 0.0)
    for name, value in (channels or {}).items():
        joint = name if name in positions else facts.hand.name(name) if facts.hand else name
        if joint not in positions:
            raise SvhdescError(f"{facts.model.name} has no joint {name!r}")
        positions[joint] = float(value)
    for coupling in facts.couplings:
        positions[coupling.joint] = float(coupling.value(positions[coupling.leader]))
    return positions


def action_scale(facts: Built) -> dict[str, float]:
    """Each actuated joint's action scale: ``ACTION_SPAN`` of its control range's width (rad per unit action)."""
    return {joint: ACTION_SPAN * (high - low) for joint, (low, high) in facts.ranges.items()}


def robot_cfg(
    variant: str | Path,
    channels: dict[str, float] | None = None,
    base: tuple[tuple[float, float, float], tuple[float, float, float, float]] | None = None,
    keyframe: str = "home",
    sites: tuple[Site, ...] = (),
) -> Any:
    """The variant as an mjlab ``EntityCfg``: the MJCF's actuators and couplings, the initial state of ``keyframe``
    (``channels`` set on top, the coupled joints following), the base at ``base`` (position, wxyz quaternion)."""
    from mjlab.actuator import XmlActuatorCfg
    from mjlab.entity import EntityArticulationInfoCfg, EntityCfg

    facts = built(variant)
    positions = pose(facts, channels, keyframe)
    pos, rot = base or ((0.0, 0.0, 0.0), (1.0, 0.0, 0.0, 0.0))
    init = EntityCfg.InitialStateCfg(pos=pos, rot=rot, joint_pos=_exact(positions), joint_vel={".*": 0.0})
    actuators = (XmlActuatorCfg(target_names_expr=tuple(exact_name(j) for j in facts.ranges)),)
    return EntityCfg(
        init_state=init,
        spec_fn=spec_fn(facts.model, sites),
        articulation=EntityArticulationInfoCfg(actuators=actuators),
    )


def exact_name(name: str) -> str:
    """A name as a regular expression matching only itself (mjlab matches names as expressions)."""
    import re

    return re.escape(name)


def _exact(values: dict[str, float]) -> dict[str, float]:
    return {exact_name(name): value for name, value in values.items()}
