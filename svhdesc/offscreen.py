"""One headless renderer: the OpenGL backend (EGL, then OSMesa), a child process per backend tried, PNG writing.

MuJoCo binds its OpenGL backend when ``mujoco`` is first imported (MUJOCO_GL), and a failed backend cannot be
swapped in the same process. So a picture is drawn by a child process per backend tried: the user's MUJOCO_GL if
set, else EGL, then OSMesa. Debian packages: EGL needs libegl1 + libgl1-mesa-dri (software rendering without a
GPU), OSMesa needs libosmesa6. ``svhdesc render`` (svhdesc.validate.render) and the wire loop's picture
(svhdesc.wireloop.mujoco_run) both draw through here.

``stage`` dresses a loaded scene for a picture the way MuJoCo Menagerie's gallery looks: a light gradient backdrop,
a light checker floor, a key light with shadows and a fill light. It changes the picture only, never the model files:
a variant's scene.xml keeps Menagerie's dark scene for the interactive viewer.
"""

from __future__ import annotations

import os
import struct
import subprocess
import sys
import zlib
from pathlib import Path
from typing import Any

from svhdesc.errors import SvhdescError

BACKENDS = ("egl", "osmesa")
INSTALL = "apt-get install libegl1 libgl1-mesa-dri (EGL) or libosmesa6 (OSMesa)"
TIMEOUT = 300  # s
USER_ERROR = 3  # a child's exit code for a bad request (unknown keyframe, bad model), not a GL problem


def backend_env(backend: str) -> dict[str, str]:
    """The environment of a child that draws with ``backend``."""
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
                env=backend_env(backend),
                capture_output=True,
                timeout=TIMEOUT,
                check=False,
            )
        except (OSError, subprocess.TimeoutExpired):
            continue
        if result.returncode == 0:
            working.append(backend)
    return working


def run_child(command: list[str], stdin: str | None = None) -> str:
    """Run ``command`` (a child that draws and writes its picture) under each backend until one succeeds;
    returns that backend. A child exiting with USER_ERROR raises its last stderr line as the user's error."""
    failures = []
    for backend in backends_to_try():
        try:
            result = subprocess.run(
                command,
                input=stdin,
                env=backend_env(backend),
                capture_output=True,
                text=True,
                timeout=TIMEOUT,
                check=False,
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


# The picture's look (RGB): backdrop top and horizon, floor checks and lines.
SKY = ((1.0, 1.0, 1.0), (0.80, 0.84, 0.88))
FLOOR = ((0.9, 0.9, 0.9), (0.8, 0.81, 0.83), (0.7, 0.72, 0.75))
FLOOR_NAME = "studio_floor"


def stage(spec: Any) -> None:
    """Replace ``spec``'s backdrop, floor look and lights with the picture's; add a floor if it has none
    (``place_floor`` puts it under the posed robot)."""
    import mujoco

    for element in [t for t in spec.textures if t.type == mujoco.mjtTexture.mjTEXTURE_SKYBOX] + list(spec.lights):
        spec.delete(element)
    spec.add_texture(
        name="studio_sky",
        type=mujoco.mjtTexture.mjTEXTURE_SKYBOX,
        builtin=mujoco.mjtBuiltin.mjBUILTIN_GRADIENT,
        rgb1=SKY[0],
        rgb2=SKY[1],
        width=512,
        height=3072,
    )
    spec.add_texture(
        name=FLOOR_NAME,
        type=mujoco.mjtTexture.mjTEXTURE_2D,
        builtin=mujoco.mjtBuiltin.mjBUILTIN_CHECKER,
        mark=mujoco.mjtMark.mjMARK_EDGE,
        rgb1=FLOOR[0],
        rgb2=FLOOR[1],
        markrgb=FLOOR[2],
        width=300,
        height=300,
    )
    floor = spec.add_material(name=FLOOR_NAME, texuniform=True, texrepeat=(8, 8), reflectance=0.0)
    floor.textures[mujoco.mjtTextureRole.mjTEXROLE_RGB] = FLOOR_NAME
    planes = [g for g in spec.geoms if g.type == mujoco.mjtGeom.mjGEOM_PLANE]
    if not planes:
        planes = [spec.worldbody.add_geom(name=FLOOR_NAME, type=mujoco.mjtGeom.mjGEOM_PLANE, size=(0, 0, 0.05))]
    for plane in planes:
        plane.material, plane.rgba, plane.group = FLOOR_NAME, (1.0, 1.0, 1.0, 1.0), 0
    # Shadows fall anywhere in the picture: the default clip (1 extent) breaks far ones into dots.
    spec.visual.quality.shadowsize, spec.visual.map.shadowclip = 8192, 3.0
    spec.visual.rgba.haze = (*SKY[1], 1.0)  # the floor fades into the backdrop's horizon
    headlight = spec.visual.headlight
    headlight.ambient, headlight.diffuse, headlight.specular = (0.3,) * 3, (0.3,) * 3, (0.1,) * 3
    directional = mujoco.mjtLightType.mjLIGHT_DIRECTIONAL
    key = spec.worldbody.add_light(name="studio_key", type=directional, dir=(0.2, 0.3, -1.0), castshadow=True)
    key.diffuse, key.specular = (0.5,) * 3, (0.3,) * 3
    fill = spec.worldbody.add_light(name="studio_fill", type=directional, dir=(-0.5, -0.3, -0.4), castshadow=False)
    fill.diffuse, fill.specular = (0.2,) * 3, (0.0,) * 3


def place_floor(model: Any, low: float) -> None:
    """Put a floor ``stage`` added just under ``low`` (the lowest drawn point, m); a scene's own floor stays."""
    import mujoco

    floor = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, FLOOR_NAME)
    if floor >= 0:
        model.geom_pos[floor][2] = low - 0.001


def draw_png(model: Any, data: Any, camera: Any, out: Path, size: tuple[int, int]) -> None:
    """In a child with MUJOCO_GL set: draw scene (group 0) and visual (group 2) geoms, collision off, to a PNG."""
    write_png(out, draw_pixels(model, data, camera, size))


def draw_pixels(model: Any, data: Any, camera: Any, size: tuple[int, int]) -> Any:
    """``draw_png``'s picture as an RGB array [height, width, 3]."""
    import mujoco
    import numpy as np

    width, height = size
    # The offscreen framebuffer must be at least the requested size.
    model.vis.global_.offwidth = max(model.vis.global_.offwidth, width)
    model.vis.global_.offheight = max(model.vis.global_.offheight, height)
    option = mujoco.MjvOption()
    option.geomgroup[:] = 0
    option.geomgroup[0] = 1  # scene geoms (the floor)
    option.geomgroup[2] = 1  # visual; collision (group 3) stays off
    renderer = mujoco.Renderer(model, height, width)
    try:
        renderer.update_scene(data, camera=camera, scene_option=option)
        return np.ascontiguousarray(renderer.render())
    finally:
        renderer.close()


def write_png(path: Path, pixels: Any) -> None:
    """RGB uint8 array -> PNG with zlib alone, so rendering needs nothing beyond mujoco."""
    height, width, _ = pixels.shape
    raw = b"".join(b"\x00" + pixels[row].tobytes() for row in range(height))

    def chunk(kind: bytes, body: bytes) -> bytes:
        return struct.pack(">I", len(body)) + kind + body + struct.pack(">I", zlib.crc32(kind + body))

    header = struct.pack(">IIBBBBB", width, height, 8, 2, 0, 0, 0)
    path.write_bytes(
        b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", header) + chunk(b"IDAT", zlib.compress(raw, 9)) + chunk(b"IEND", b"")
    )
