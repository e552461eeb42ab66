"""svhdesc: simulation-ready SCHUNK SVH hand and UR5 + SVH models (URDF + MJCF) from one source.

import svhdesc
svhdesc.variants()                      # ['svh_left', 'svh_right', 'ur5_svh_right']
model = svhdesc.get("ur5_svh_right")    # .urdf_path .mjcf_path .scene_path
svhdesc.URDF_PATH, svhdesc.MJCF_PATH    # the UR5 + right hand
m = svhdesc.load_mujoco("svh_right")    # imports mujoco only here
svhdesc.load_pinocchio, svhdesc.load_pybullet, svhdesc.load_drake, svhdesc.load_dart  # see svhdesc.loaders
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

from .paths import generated_dir

__all__ = [
    "Model",
    "get",
    "variants",
    "load_mujoco",
    "load_pinocchio",
    "load_pybullet",
    "load_drake",
    "load_dart",
    "URDF_PATH",
    "MJCF_PATH",
    "SCENE_PATH",
]
DEFAULT_VARIANT = "ur5_svh_right"


@dataclass(frozen=True)
class Model:
    name: str
    directory: Path

    @property
    def urdf_path(self) -> Path:
        return self.directory / f"{self.name}.urdf"

    @property
    def mjcf_path(self) -> Path:
        return self.directory / f"{self.name}.xml"

    @property
    def scene_path(self) -> Path:
        return self.directory / "scene.xml"


def variants() -> list[str]:
    root = generated_dir()
    return sorted(p.name for p in root.iterdir() if (p / f"{p.name}.xml").is_file()) if root.is_dir() else []


def get(name: str) -> Model:
    if name not in variants():
        raise KeyError(f"unknown variant {name!r}; available: {', '.join(variants())}")
    return Model(name, generated_dir() / name)


_LOADERS = {"load_mujoco", "load_pinocchio", "load_pybullet", "load_drake", "load_dart"}


def __getattr__(attr: str) -> Any:
    # Loaders and module constants resolved lazily: importing svhdesc touches no files and no engine.
    if attr in _LOADERS:
        from . import loaders

        return getattr(loaders, attr)
    constants = {"URDF_PATH": "urdf_path", "MJCF_PATH": "mjcf_path", "SCENE_PATH": "scene_path"}
    if attr in constants:
        return getattr(get(DEFAULT_VARIANT), constants[attr])
    raise AttributeError(f"module 'svhdesc' has no attribute {attr!r}")
