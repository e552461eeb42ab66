"""Offscreen render of a variant's scene.xml (visual geoms only) to a PNG.

The picture is drawn by a child process (``python -m svhdesc.validate.render``) per OpenGL backend tried, through
``svhdesc.offscreen`` (backend choice, PNG writing).
"""

from __future__ import annotations

import json
import math
import sys
from pathlib import Path
from typing import Any

from svhdesc.errors import SvhdescError
from svhdesc.extras import require
from svhdesc.offscreen import USER_ERROR, draw_png, place_floor, run_child, stage


def parse_size(text: str) -> tuple[int, int]:
    try:
        width, height = (int(v) for v in text.lower().split("x"))
    except ValueError:
        raise SvhdescError(f"--size must be WIDTHxHEIGHT, e.g. 640x480 (got '{text}')") from None
    if not (16 <= width <= 8192 and 16 <= height <= 8192):
        raise SvhdescError(f"--size {text}: each side must be 16 to 8192 pixels")
    return width, height


def scene_file(target: Path) -> Path:
    """A variant directory's scene.xml (or the MJCF itself when there is no scene), or an XML file."""
    if target.is_file():
        return target
    for candidate in (target / "scene.xml", target / f"{target.name}.xml"):
        if candidate.is_file():
            return candidate
    raise SvhdescError(f"{target}: no scene.xml or {target.name}.xml (build the variant first: svhdesc build)")


def render(
    target: Path, out: Path, keyframe: str | None, size: tuple[int, int], view: tuple[float, float] | None = None
) -> str:
    """Render ``target`` (variant directory or XML) to ``out``; returns the GL backend used."""
    return render_many(target, [(keyframe or "", out)], size, view)


def render_many(
    target: Path,
    pictures: list[tuple[str, Path]],
    size: tuple[int, int],
    view: tuple[float, float] | None = None,
    studio: bool = True,
    focus: tuple[str, ...] = (),
) -> str:
    """A picture per (keyframe, file) of ``target``, all from one camera that frames every pose ('' is 'home'
    if the model has it, else the model's reference pose), looking from ``view`` (azimuth, elevation in degrees;
    default the scene's), in the light studio (``svhdesc.offscreen.stage``) or, without ``studio``, in the
    scene's own backdrop, floor and lights. With ``focus`` (body names), the camera frames those bodies and
    everything they carry, not the whole scene. Returns the GL backend used."""
    require("mujoco", "'svhdesc render'", "sim")  # before blaming OpenGL for a missing package
    import mujoco

    scene = scene_file(target)
    try:
        model = mujoco.MjModel.from_xml_path(str(scene))
    except ValueError as exc:
        raise SvhdescError(f"{scene}: {str(exc).strip()}") from None
    for keyframe, _ in pictures:
        if keyframe and mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_KEY, keyframe) < 0:
            names = [model.key(k).name for k in range(model.nkey)]
            raise SvhdescError(f"{scene}: no keyframe '{keyframe}' (keyframes: {', '.join(names) or 'none'})")
    for _, out in pictures:
        out.parent.mkdir(parents=True, exist_ok=True)
    request = {
        "scene": str(scene),
        "size": list(size),
        "view": None if view is None else list(view),
        "studio": studio,
        "focus": list(focus),
        "pictures": [[keyframe, str(out)] for keyframe, out in pictures],
    }
    return run_child([sys.executable, "-m", "svhdesc.validate.render"], stdin=json.dumps(request))


def _carried_by(model: Any, body: int, roots: set[int]) -> bool:
    while body > 0:
        if body in roots:
            return True
        body = int(model.body_parentid[body])
    return False


def drawn_points(model: Any, data: Any, focus: tuple[str, ...] = ()) -> Any:
    """World corners of the bounding box of every geom a picture draws (groups 0 and 2), planes left out; with
    ``focus``, only the geoms of those bodies and their descendants."""
    import mujoco
    import numpy as np

    plane = int(mujoco.mjtGeom.mjGEOM_PLANE)
    roots = {int(model.body(name).id) for name in focus}
    geoms = [
        g
        for g in range(model.ngeom)
        if model.geom_group[g] in (0, 2)
        and int(model.geom_type[g]) != plane
        and model.geom_rgba[g][3] > 0
        and (not roots or _carried_by(model, int(model.geom_bodyid[g]), roots))
    ]
    signs = np.array([(x, y, z) for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], dtype=float)
    box = model.geom_aabb[geoms]  # centre and half sizes, in the geom's frame
    local = box[:, None, :3] + signs[None] * box[:, None, 3:]
    rotations = data.geom_xmat[geoms].reshape(-1, 3, 3)
    return (data.geom_xpos[geoms][:, None, :] + np.einsum("gij,gkj->gki", rotations, local)).reshape(-1, 3)


def frame(model: Any, points: Any, camera: Any, width: int, height: int, margin: float = 0.06) -> None:
    """Free camera at the scene's azimuth/elevation, as close as keeps ``points`` inside the picture with
    ``margin`` (a fraction of each side) left free, and centred on them."""
    import mujoco
    import numpy as np

    azimuth, elevation = np.radians(model.vis.global_.azimuth), np.radians(model.vis.global_.elevation)
    forward = np.array([np.cos(elevation) * np.cos(azimuth), np.cos(elevation) * np.sin(azimuth), np.sin(elevation)])
    right = np.array([np.sin(azimuth), -np.cos(azimuth), 0.0])
    up = np.cross(right, forward)
    half_y = math.tan(math.radians(model.vis.global_.fovy) / 2.0) * (1.0 - 2.0 * margin)
    half_x = half_y * width / height
    centre = (points.min(axis=0) + points.max(axis=0)) / 2.0
    distance = 1.0
    for _ in range(4):  # perspective: centring moves the fit, a few rounds settle it
        relative = points - centre
        x, y, z = relative @ right, relative @ up, relative @ forward
        distance = float(max(np.max(np.abs(x) / half_x - z), np.max(np.abs(y) / half_y - z)))
        u, v = x / (distance + z), y / (distance + z)
        centre = centre + distance * ((u.max() + u.min()) / 2.0 * right + (v.max() + v.min()) / 2.0 * up)
    camera.type = mujoco.mjtCamera.mjCAMERA_FREE
    camera.lookat[:] = centre
    camera.azimuth, camera.elevation = model.vis.global_.azimuth, model.vis.global_.elevation
    camera.distance = distance


def _pose(model: Any, data: Any, keyframe: str) -> bool:
    """Put ``data`` in ``keyframe`` ('': 'home' if the model has it, else the reference pose); False if missing."""
    import mujoco

    key = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_KEY, keyframe or "home")
    if keyframe and key < 0:
        return False
    if key >= 0:
        mujoco.mj_resetDataKeyframe(model, data, key)
    else:
        mujoco.mj_resetData(model, data)
    mujoco.mj_forward(model, data)
    return True


def _child() -> int:
    """Runs in the child process, with MUJOCO_GL already set by the parent: a picture per (keyframe, file) of
    the request on stdin (render_many's arguments)."""
    import mujoco
    import numpy as np

    request = json.loads(sys.stdin.read())
    width, height = request["size"]
    spec = mujoco.MjSpec.from_file(request["scene"])
    if request["studio"]:
        stage(spec)
    if request["view"] is not None:
        spec.visual.global_.azimuth, spec.visual.global_.elevation = request["view"]
    model = spec.compile()
    data = mujoco.MjData(model)
    focus = tuple(request["focus"])
    drawn, framed = [], []
    for keyframe, _ in request["pictures"]:
        if not _pose(model, data, keyframe):
            print(f"no keyframe '{keyframe}'", file=sys.stderr)
            return USER_ERROR
        drawn.append(drawn_points(model, data))
        framed.append(drawn_points(model, data, focus))
    place_floor(model, float(np.concatenate(drawn)[:, 2].min()))
    camera = mujoco.MjvCamera()
    frame(model, np.concatenate(framed), camera, width, height)
    for keyframe, out in request["pictures"]:
        _pose(model, data, keyframe)
        draw_png(model, data, camera, Path(out), (width, height))
    return 0


if __name__ == "__main__":
    sys.exit(_child())
