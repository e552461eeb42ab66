"""A task's scene: the variant's built model (its batch model, or the main one), the robot's base placed, the task's
objects and table added with MjSpec, and the physics step and Warp capacities the task states."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from svhdesc.errors import SvhdescError
from svhdesc.extras import require
from svhdesc.learn.spec import Scene, Shape

SOURCES = ("batch", "main")
# An object's contacts resist spinning about their normal (condim 4, torsional friction about what a 2 cm contact
# patch gives: 2/3 x radius x the sliding coefficient). Without it a cube on the batch model's single contact point
# per hull pair spins almost freely: at action 0, 16 cubes in the palm turned at 0.68 rad/s on average on the main
# model, 0.009 on the batch one; with it, 0.0018 and 0.0048.
OBJECT_CONDIM = 4
TORSION = 0.01  # m  # the variant's scene_batch.xml (Warp, MJX) or scene.xml (noslip, multi-contact)


def scene_file(variant: str, source: str) -> Path:
    from svhdesc.model import get

    if source not in SOURCES:
        raise SvhdescError(f"unknown model source {source!r} (known: {', '.join(SOURCES)})")
    try:
        built = get(variant)
    except KeyError as exc:
        raise SvhdescError(str(exc.args[0])) from None
    path = built.batch_scene_path if source == "batch" else built.scene_path
    if not path.is_file():
        raise SvhdescError(f"{path}: no such scene (rebuild: svhdesc build {variant})")
    return path


def robot_root(spec: Any) -> Any:
    """The world's child body that carries the robot (the one with joints below it)."""
    roots = [body for body in spec.worldbody.bodies if _has_joints(body)]
    if len(roots) != 1:
        raise SvhdescError(f"expected one robot below the world, found {len(roots)}")
    return roots[0]


def _has_joints(body: Any) -> bool:
    return bool(body.joints) or any(_has_joints(child) for child in body.bodies)


def add_shape(spec: Any, shape: Shape) -> None:
    mujoco = require("mujoco", "svhdesc.learn", "rl")
    kinds = {
        "box": mujoco.mjtGeom.mjGEOM_BOX,
        "cylinder": mujoco.mjtGeom.mjGEOM_CYLINDER,
        "sphere": mujoco.mjtGeom.mjGEOM_SPHERE,
    }
    if shape.kind not in kinds:
        raise SvhdescError(f"object {shape.name}: unknown shape {shape.kind!r} (known: {', '.join(kinds)})")
    body = spec.worldbody.add_body(name=shape.name, pos=(0.0, 0.0, -1.0))
    body.add_freejoint(name=f"{shape.name}_joint")
    body.add_geom(
        name=shape.name,
        type=kinds[shape.kind],
        size=shape.size,
        mass=shape.mass,
        rgba=shape.rgba,
        contype=1,
        conaffinity=1,
        condim=OBJECT_CONDIM,
        friction=(1.0, TORSION, 0.0001),
    )


def add_table(spec: Any, half: tuple[float, float, float], centre: tuple[float, float, float]) -> None:
    """A table: a box to see, and a plane at its top to collide with. MuJoCo's box-box and primitive-box contacts
    give one point where the batch model's ``multiccd`` is off, and a cylinder standing on one point tips over; a
    plane gives every primitive its full contact patch."""
    mujoco = require("mujoco", "svhdesc.learn", "rl")
    top = (centre[0], centre[1], centre[2] + half[2])
    spec.worldbody.add_geom(
        name="table",
        type=mujoco.mjtGeom.mjGEOM_BOX,
        size=half,
        pos=centre,
        rgba=(0.55, 0.45, 0.35, 1.0),
        contype=0,
        conaffinity=0,
    )
    spec.worldbody.add_geom(
        name="table_top",
        type=mujoco.mjtGeom.mjGEOM_PLANE,
        size=(half[0], half[1], 0.01),
        pos=top,
        rgba=(0.0, 0.0, 0.0, 0.0),
        contype=1,
        conaffinity=1,
        friction=(1.0, 0.005, 0.0001),
    )


def compose(scene: Scene, source: str = "batch") -> Any:
    """The task's compiled ``mujoco.MjModel``."""
    spec = compose_spec(scene, source)
    try:
        return spec.compile()
    except ValueError as exc:
        raise SvhdescError(f"task scene of {scene.variant}: {exc}") from None


def compose_spec(scene: Scene, source: str = "batch") -> Any:
    """The task's ``mujoco.MjSpec``, not yet compiled."""
    mujoco = require("mujoco", "svhdesc.learn", "rl")
    spec = mujoco.MjSpec.from_file(str(scene_file(scene.variant, source)))
    dress(spec, scene)
    return spec


def dress(spec: Any, scene: Scene) -> None:
    """Turn a variant's loaded scene into the task's: the robot's base placed, the objects and the table added, the
    physics step, contacts and Warp capacities set (what ``svhdesc.sim.Simulation``'s ``edit`` takes, too)."""
    mujoco = require("mujoco", "svhdesc.learn", "rl")
    root = robot_root(spec)
    root.pos, root.quat = scene.base_pose
    for shape in scene.objects:
        add_shape(spec, shape)
    if scene.table is not None:
        add_table(spec, *scene.table)
    spec.option.timestep = scene.physics_dt
    if not scene.contacts:
        spec.option.disableflags |= mujoco.mjtDisableBit.mjDSBL_CONTACT
    spec.nconmax, spec.njmax = scene.nconmax, scene.njmax
