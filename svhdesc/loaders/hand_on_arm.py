"""A built hand attached to any MJCF arm at run time, the Menagerie way: ``mujoco.MjSpec``'s attach.

    spec = svhdesc.attach("ur5e.xml", "svh_right", parent="wrist_3_link", pos=(0, 0, 0.032))
    model = spec.compile()

The hand comes whole from its built MJCF (read through ``svhdesc.model``): its default classes, joint equalities
(the couplings), servos, touch sensor and contact exclusions. What attach alone would not do, this does as the
compiler does for a built arm variant:

- contact exclusions across the seam: the arm's bodies next to the hand's in the tree (parent and grandparent,
  looking through bodies without collision geoms) and the pairs touching at qpos 0;
- keyframes merged by name (``home``, ``test``, the grasps): each part takes its own keyframe of that name, else its
  ``home``, else its qpos0;
- the smaller timestep and the larger ``noslip_iterations`` of the two (the couplings' solref needs the hand's 1 ms).

Names are kept as built (``prefix=""``), so the driver's joint names stay; MuJoCo warns that a model attached with
an empty prefix may not save (``to_xml``) correctly: give a prefix to save one.
"""

from __future__ import annotations

import os
import warnings
from collections.abc import Sequence
from typing import Any

import numpy as np

from svhdesc.loaders._common import require
from svhdesc.model import get, scalar_joints

HOME = "home"


def attach(
    arm: Any,
    hand: str | os.PathLike[str] = "svh_right",
    *,
    parent: str,
    pos: Sequence[float] = (0.0, 0.0, 0.0),
    quat: Sequence[float] = (1.0, 0.0, 0.0, 0.0),
    prefix: str = "",
) -> Any:
    """``arm`` (a ``mujoco.MjSpec``, left unchanged, or an MJCF path) with the built ``hand`` (a variant name or
    folder) fixed to its body ``parent`` at ``pos`` / ``quat`` (w x y z) in that body's frame: a new MjSpec."""
    mujoco = require("mujoco", "svhdesc.attach")
    spec = arm.copy() if isinstance(arm, mujoco.MjSpec) else mujoco.MjSpec.from_file(os.fspath(arm))
    body = spec.body(parent)
    if body is None:
        names = ", ".join(b.name for b in spec.bodies if b.name)
        raise ValueError(f"attach: the arm has no body {parent!r} (bodies: {names})")
    child = mujoco.MjSpec.from_file(str(get(hand).mjcf_path))
    arm_keys, hand_keys = _keyframes(spec), _keyframes(child)
    for owner in (spec, child):
        for key in list(owner.keys):
            owner.delete(key)
    timestep = min(spec.option.timestep, child.option.timestep)
    noslip = max(spec.option.noslip_iterations, child.option.noslip_iterations)
    for owner in (spec, child):  # equal, so MuJoCo's attach reports no conflict
        owner.option.timestep, owner.option.noslip_iterations = timestep, noslip
    arm_bodies = {b.name for b in spec.bodies}
    frame = body.add_frame(pos=list(pos), quat=list(quat))
    with warnings.catch_warnings():  # said once in the module's docstring, not at every compile here
        warnings.filterwarnings("ignore", message="Attaching a spec with an empty prefix")
        frame.attach_body(_hand_root(child), prefix, "")
        _exclude_seam(mujoco, spec, arm_bodies)
        _merge_keyframes(spec, arm_keys, hand_keys)
    return spec


def _hand_root(spec: Any) -> Any:
    """The hand's base body: the one body under the model's root body, when that root is a bare holder."""
    root = spec.worldbody.first_body()
    children = list(root.bodies)
    bare = not root.geoms and not root.joints and not root.sites
    return children[0] if bare and len(children) == 1 else root


def _keyframes(spec: Any) -> dict[str, tuple[dict[str, float], dict[str, float]]]:
    """Each keyframe by name: (joint name -> position of each scalar joint, actuator name -> control)."""
    model = spec.compile()
    keys = {}
    for k in range(model.nkey):
        qpos = {model.joint(j).name: float(model.key_qpos[k, model.jnt_qposadr[j]]) for j in scalar_joints(model)}
        ctrl = {model.actuator(a).name: float(model.key_ctrl[k, a]) for a in range(model.nu)}
        keys[model.key(k).name] = (qpos, ctrl)
    return keys


def _merge_keyframes(spec: Any, arm: dict[str, Any], hand: dict[str, Any]) -> None:
    model = spec.compile()
    for name in dict.fromkeys([*arm, *hand]):
        qpos, ctrl = model.qpos0.copy(), np.zeros(model.nu)
        for part in (arm, hand):
            positions, controls = part.get(name, part.get(HOME, ({}, {})))
            for joint, value in positions.items():
                qpos[model.jnt_qposadr[model.joint(joint).id]] = value
            for actuator, value in controls.items():
                ctrl[model.actuator(actuator).id] = value
        spec.add_key(name=name, qpos=qpos.tolist(), ctrl=ctrl.tolist())


def _exclude_seam(mujoco: Any, spec: Any, arm_bodies: set[str]) -> None:
    """Arm-hand body pairs next to each other in the tree, then those touching at qpos 0, never collide."""
    model = spec.compile()
    _add_crossing(spec, model, _adjacent(model), arm_bodies)
    model = spec.compile()
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    touching = {(int(model.geom_bodyid[c.geom1]), int(model.geom_bodyid[c.geom2])) for c in data.contact[: data.ncon]}
    _add_crossing(spec, model, touching, arm_bodies)


def _adjacent(model: Any) -> set[tuple[int, int]]:
    """Bodies with collision geoms at most two steps apart (parent, grandparent, sibling), looking through bodies
    without: the compiler's rule for a built variant (MoveIt's "adjacent" pairs)."""
    colliding = {
        int(model.geom_bodyid[g]) for g in range(model.ngeom) if model.geom_contype[g] or model.geom_conaffinity[g]
    }

    def up(body: int | None) -> int | None:
        if body is None:
            return None
        body = int(model.body_parentid[body])
        while body > 0 and body not in colliding:
            body = int(model.body_parentid[body])
        return body if body in colliding else None

    pairs = set()
    for body in colliding:
        parent = up(body)
        pairs.update((other, body) for other in (parent, up(parent)) if other is not None)
        if parent is not None:
            pairs.update((other, body) for other in colliding if other != body and up(other) == parent)
    return pairs


def _add_crossing(spec: Any, model: Any, pairs: set[tuple[int, int]], arm_bodies: set[str]) -> None:
    added = set()
    for first, second in sorted(pairs):
        names = (model.body(first).name, model.body(second).name)
        if (names[0] in arm_bodies) != (names[1] in arm_bodies) and frozenset(names) not in added:
            added.add(frozenset(names))
            spec.add_exclude(bodyname1=names[0], bodyname2=names[1])
