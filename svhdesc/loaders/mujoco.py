"""MuJoCo: the MJCF (joint equalities carry the couplings), or its scene with floor and light."""

from __future__ import annotations

from typing import Any

from svhdesc.loaders._common import require
from svhdesc.model import get


def load_mujoco(name: str = "ur5_svh_right", scene: bool = False) -> Any:
    """Compile the variant's MJCF (or ``scene.xml`` when ``scene``) into a ``mujoco.MjModel``."""
    mujoco = require("mujoco", "load_mujoco")
    model = get(name)
    return mujoco.MjModel.from_xml_path(str(model.scene_path if scene else model.mjcf_path))
