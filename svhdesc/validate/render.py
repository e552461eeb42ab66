"""Offscreen render of a variant's scene.xml (visual geoms only) to a PNG.

MuJoCo binds its OpenGL backend when ``mujoco`` is first imported (MUJOCO_GL), and a failed backend
cannot be swapped in the same process. So the picture is drawn by a child process
(``python -m svhdesc.validate.render``) per backend tried: the user's MUJOCO_GL if set, else EGL,
then OSMesa. Debian packages: EGL needs libegl1 + libgl1-mesa-dri (software rendering without a
GPU), OSMesa needs libosmesa6.
"""

from __future__ import annotations

import math
import os
import struct
import subprocess
import sys
import zlib
from pathlib import Path
from typing import Any

from svhdesc.errors import SvhdescError
from svhdesc.extras import require

BACKENDS = ("egl", "osmesa")
INSTALL = "apt-get install libegl1 libgl1-mesa-dri (EGL) or libosmesa6 (OSMesa)"
TIMEOUT = 300  # s
USER_ERROR = 3  # the child's exit code for a bad request (unknown keyframe, bad model), not a GL problem


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


def _backend_env(backend: str) -> dict[str, str]:
    env = dict(os.environ, MUJOCO_GL=backend)
    if backend in BACKENDS:
        env.setdefault("PYOPENGL_PLATFORM", backend)
    return env


def backends_to_try() -> list[str]:
    user = os.environ.get("MUJOCO_GL", "").strip().lower()
    return [user] if user else list(BACKENDS)


def available_backends() -> list[str]:
    """Backends that can create an offscreen GL context here (each probed in a child process)."""
    probe = "import mujoco; c = mujoco.GLContext(16, 16); c.make_current(); c.free()"
    working = []
    for backend in backends_to_try():
        try:
            result = subprocess.run(
                [sys.executable, "-c", probe],
                env=_backend_env(backend),
                capture_output=True,
                timeout=TIMEOUT,
                check=False,
            )
        except (OSError, subprocess.TimeoutExpired):
            continue
        if result.returncode == 0:
            working.append(backend)
    return working


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
    failures = []
    for backend in backends_to_try():
        command = [
            sys.executable,
            "-m",
            "svhdesc.validate.render",
            str(scene),
            str(out),
            keyframe or "",
            f"{size[0]}x{size[1]}",
        ]
        try:
            result = subprocess.run(
                command, env=_backend_env(backend), capture_output=True, text=True, timeout=TIMEOUT, check=False
            )
        except subprocess.TimeoutExpired:
            failures.append(f"{backend}: timed out")
            continue
        if result.returncode == 0:
            return backend
        message = (result.stderr.strip().splitlines() or ["no message"])[-1]
        if result.returncode == USER_ERROR:
            raise SvhdescError(message)
        failures.append(f"{backend}: {message}")
    raise SvhdescError(f"no offscreen OpenGL backend works here ({'; '.join(failures)}); install {INSTALL}")


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
    import numpy as np

    width, height = (int(v) for v in size.split("x"))
    model = mujoco.MjModel.from_xml_path(scene)
    # The offscreen framebuffer must be at least the requested size.
    model.vis.global_.offwidth = max(model.vis.global_.offwidth, width)
    model.vis.global_.offheight = max(model.vis.global_.offheight, height)
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
    option = mujoco.MjvOption()
    option.geomgroup[:] = 0
    option.geomgroup[0] = 1  # scene geoms (the floor)
    option.geomgroup[2] = 1  # visual; collision (group 3) stays off
    renderer = mujoco.Renderer(model, height, width)
    try:
        renderer.update_scene(data, camera=camera, scene_option=option)
        pixels = np.ascontiguousarray(renderer.render())
    finally:
        renderer.close()
    _write_png(Path(out), pixels)
    return 0


def _write_png(path: Path, pixels: Any) -> None:
    """RGB uint8 array -> PNG with zlib alone, so rendering needs nothing beyond mujoco."""
    height, width, _ = pixels.shape
    raw = b"".join(b"\x00" + pixels[row].tobytes() for row in range(height))

    def chunk(kind: bytes, body: bytes) -> bytes:
        return struct.pack(">I", len(body)) + kind + body + struct.pack(">I", zlib.crc32(kind + body))

    header = struct.pack(">IIBBBBB", width, height, 8, 2, 0, 0, 0)
    path.write_bytes(
        b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", header) + chunk(b"IDAT", zlib.compress(raw, 9)) + chunk(b"IEND", b"")
    )


if __name__ == "__main__":
    sys.exit(_child(*sys.argv[1:5]))
