"""svhdesc: simulation-ready SCHUNK SVH hand and UR5 + SVH models (URDF + MJCF) from one source.

import svhdesc
svhdesc.variants()                      # ['svh_left', 'svh_right', 'ur5_svh_right']
model = svhdesc.get("ur5_svh_right")    # .urdf_path .mjcf_path .scene_path .batch_scene_path
svhdesc.URDF_PATH, svhdesc.MJCF_PATH    # the UR5 + right hand
m = svhdesc.load_mujoco("svh_right")    # imports mujoco only here
model.package_name                      # each variant folder is a ROS package (package://NAME/assets/...)
model.absolute_urdf_path()              # the URDF with absolute mesh paths, for tools without ROS
svhdesc.load_pinocchio, svhdesc.load_pybullet, svhdesc.load_drake, svhdesc.load_dart  # see svhdesc.loaders
spec = svhdesc.attach("arm.xml", "svh_right", parent="tool0", pos=(0, 0, 0.032))  # mujoco.MjSpec (docs/arms.md)
"""

from __future__ import annotations

from typing import Any

from svhdesc.model import DEFAULT_VARIANT, Model, get, variants

__all__ = [
    "Model",
    "get",
    "variants",
    "load_mujoco",
    "load_pinocchio",
    "load_pybullet",
    "load_drake",
    "load_dart",
    "attach",
    "URDF_PATH",
    "MJCF_PATH",
    "SCENE_PATH",
]


_LOADERS = {"load_mujoco", "load_pinocchio", "load_pybullet", "load_drake", "load_dart", "load_newton", "attach"}


def __getattr__(attr: str) -> Any:
    # Loaders and module constants resolved lazily: importing svhdesc touches no files and no engine.
    if attr in _LOADERS:
        from svhdesc import loaders

        return getattr(loaders, attr)
    constants = {"URDF_PATH": "urdf_path", "MJCF_PATH": "mjcf_path", "SCENE_PATH": "scene_path"}
    if attr in constants:
        return getattr(get(DEFAULT_VARIANT), constants[attr])
    raise AttributeError(f"module 'svhdesc' has no attribute {attr!r}")
