"""One headless renderer: the OpenGL backend (EGL, then OSMesa), a child process per backend tried, PNG writing.

MuJoCo binds its OpenGL backend when ``mujoco`` is first imported (MUJOCO_GL), and a failed backend cannot be
swapped in the same process. So a picture is drawn by a child process per backend tried: the user's MUJOCO_GL if
set, else EGL, then OSMesa. Debian packages: EGL needs libegl1 + libgl1-mesa-dri (software rendering without a
GPU), OSMesa needs libosmesa6. ``svhdesc render`` (svhdesc.validate.render) and the wire loop's picture
(svhdesc.wireloop.mujoco_run) both draw through here.
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


def draw_png(model: Any, data: Any, camera: Any, out: Path, size: tuple[int, int]) -> None:
    """In a child with MUJOCO_GL set: draw scene (group 0) and visual (group 2) geoms, collision off, to a PNG."""
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
        pixels = np.ascontiguousarray(renderer.render())
    finally:
        renderer.close()
    write_png(out, pixels)


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
