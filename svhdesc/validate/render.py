"""Offscreen render of a variant's scene.xml (visual geoms only) to a PNG.

The picture is drawn by a child process (``python -m svhdesc.validate.render``) per OpenGL backend tried, through
``svhdesc.offscreen`` (backend choice, PNG writing).
"""

from __future__ import annotations

import math
import sys
from pathlib import Path
from typing import Any

from svhdesc.errors import SvhdescError
from svhdesc.extras import require
from svhdesc.offscreen import USER_ERROR, draw_png, run_child


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


def render(target: Path, out: Path, keyframe: str | None, size: tuple[int, int]) -> str:
    """Render ``target`` (variant directory or XML) to ``out``; returns the GL backend used."""
    require("mujoco", "'svhdesc render'", "sim")  # before blaming OpenGL for a missing package
    import mujoco

    scene = scene_file(target)
    try:
        model = mujoco.MjModel.from_xml_path(str(scene))
    except ValueError as exc:
        raise SvhdescError(f"{scene}: {str(exc).strip()}") from None
    if keyframe is not None and mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_KEY, keyframe) < 0:
        names = [model.key(k).name for k in range(model.nkey)]
        raise SvhdescError(f"{scene}: no keyframe '{keyframe}' (keyframes: {', '.join(names) or 'none'})")
    out.parent.mkdir(parents=True, exist_ok=True)
    command = [
        sys.executable,
        "-m",
        "svhdesc.validate.render",
        str(scene),
        str(out),
        keyframe or "",
        f"{size[0]}x{size[1]}",
    ]
    return run_child(command)


def _frame_camera(model: Any, data: Any, camera: Any) -> None:
    """Free camera at the scene's azimuth/elevation, looking at the visual geoms' bounding sphere."""
    import mujoco
    import numpy as np

    visual = [g for g in range(model.ngeom) if model.geom_group[g] == 2]
    geoms = visual or list(range(model.ngeom))
    # Planes (floors) have an infinite bound and would swallow the frame.
    geoms = [g for g in geoms if int(model.geom_type[g]) != int(mujoco.mjtGeom.mjGEOM_PLANE)]
    centres = data.geom_xpos[geoms]
    radii = model.geom_rbound[geoms]
    low, high = (centres - radii[:, None]).min(axis=0), (centres + radii[:, None]).max(axis=0)
    centre = (low + high) / 2.0
    radius = float(np.max(np.linalg.norm(centres - centre, axis=1) + radii))
    camera.type = mujoco.mjtCamera.mjCAMERA_FREE
    camera.lookat[:] = centre
    camera.azimuth = model.vis.global_.azimuth
    camera.elevation = model.vis.global_.elevation
    camera.distance = radius  # set properly by _fit once the aspect ratio is known


def _fit(model: Any, camera: Any, width: int, height: int) -> None:
    half_fovy = math.radians(model.vis.global_.fovy) / 2.0
    half_fovx = math.atan(math.tan(half_fovy) * width / height)
    radius = camera.distance
    camera.distance = 1.05 * radius / math.sin(min(half_fovy, half_fovx))


def _child(scene: str, out: str, keyframe: str, size: str) -> int:
    """Runs in the child process, with MUJOCO_GL already set by the parent."""
    import mujoco

    width, height = (int(v) for v in size.split("x"))
    model = mujoco.MjModel.from_xml_path(scene)
    data = mujoco.MjData(model)
    key = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_KEY, keyframe or "home")
    if keyframe and key < 0:
        print(f"no keyframe '{keyframe}'", file=sys.stderr)
        return USER_ERROR
    if key >= 0:
        mujoco.mj_resetDataKeyframe(model, data, key)
    mujoco.mj_forward(model, data)
    camera = mujoco.MjvCamera()
    _frame_camera(model, data, camera)
    _fit(model, camera, width, height)
    draw_png(model, data, camera, Path(out), (width, height))
    return 0


if __name__ == "__main__":
    sys.exit(_child(*sys.argv[1:5]))
