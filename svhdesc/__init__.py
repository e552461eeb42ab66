"""svhdesc: simulation-ready SCHUNK SVH hand and UR5 + SVH models (URDF + MJCF) from one source.

import svhdesc
svhdesc.variants()                      # ['svh_left', 'svh_right', 'ur5_svh_right']
model = svhdesc.get("ur5_svh_right")    # .urdf_path .mjcf_path .scene_path .batch_scene_path
svhdesc.URDF_PATH, svhdesc.MJCF_PATH    # the UR5 + right hand
m = svhdesc.load_mujoco("svh_right")    # imports mujoco only here
model.package_name                      # each variant folder is a ROS package (package://NAME/assets/...)
model.absolute_urdf_path()              # the URDF with absolute mesh paths, for tools without ROS
svhdesc.load_pinocchio, svhdesc.load_pybullet, svhdesc.load_drake, svhdesc.load_dart  # see svhdesc.loaders
"""

from __future__ import annotations

import hashlib
import os
import tempfile
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal

from svhdesc.paths import generated_dir

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

    @property
    def batch_path(self) -> Path:
        """The batch model for MuJoCo Warp / MJX (svhdesc.batch)."""
        return self.directory / f"{self.name}_batch.xml"

    @property
    def batch_scene_path(self) -> Path:
        return self.directory / "scene_batch.xml"

    @property
    def package_name(self) -> str:
        """The ROS package this folder is (put its parent on ROS_PACKAGE_PATH)."""
        from svhdesc.compiler.source.packages import package_name_of

        return package_name_of(self.directory) or self.name

    def urdf_text(self, uris: Literal["package", "file", "path"] = "package") -> str:
        """The URDF with mesh URIs as shipped (package://), as file:// URIs, or as plain absolute paths."""
        text = self.urdf_path.read_text()
        if uris == "package":
            return text
        if uris not in ("file", "path"):
            raise ValueError(f"uris must be 'package', 'file' or 'path', not {uris!r}")
        from lxml import etree

        from svhdesc.compiler.source.packages import local_mesh_path

        tree = etree.fromstring(text.encode())
        for compiler in tree.iterfind("mujoco/compiler[@meshdir]"):  # MuJoCo's importer, from anywhere too
            compiler.set("meshdir", str((self.directory / compiler.get("meshdir")).resolve()))
        for mesh in tree.iter("mesh"):
            path = local_mesh_path(mesh.get("filename", ""), self.directory)
            if path is not None:
                absolute = path.resolve()
                mesh.set("filename", absolute.as_uri() if uris == "file" else str(absolute))
        return etree.tostring(tree, xml_declaration=True, encoding="utf-8").decode()

    def absolute_urdf_path(self, uris: Literal["file", "path"] = "path") -> Path:
        """A URDF file whose meshes are absolute (for pybullet, pinocchio, Drake, DART without ROS), cached by
        content under $XDG_CACHE_HOME/svhdesc/urdf; the shipped files stay untouched."""
        text = self.urdf_text(uris)
        digest = hashlib.sha256(text.encode()).hexdigest()[:16]
        cache = Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache") / "svhdesc" / "urdf"
        path = cache / f"{self.name}-{digest}.urdf"
        if not path.is_file():
            cache.mkdir(parents=True, exist_ok=True)
            with tempfile.NamedTemporaryFile("w", dir=cache, delete=False, suffix=".tmp") as handle:
                handle.write(text)
            os.replace(handle.name, path)  # atomic: a reader never sees half a file
        return path


def variants() -> list[str]:
    root = generated_dir()
    return sorted(p.name for p in root.iterdir() if (p / f"{p.name}.xml").is_file()) if root.is_dir() else []


def get(name: str | os.PathLike[str]) -> Model:
    """A shipped variant by name, or any built variant by its folder (``<folder>/<folder name>.xml``)."""
    folder = Path(name)
    if folder.is_dir() and (folder / f"{folder.name}.xml").is_file():
        return Model(folder.name, folder.resolve())
    name = str(name)
    if name not in variants():
        raise KeyError(f"unknown variant {name!r}; available: {', '.join(variants())}")
    return Model(name, generated_dir() / name)


_LOADERS = {"load_mujoco", "load_pinocchio", "load_pybullet", "load_drake", "load_dart"}


def __getattr__(attr: str) -> Any:
    # Loaders and module constants resolved lazily: importing svhdesc touches no files and no engine.
    if attr in _LOADERS:
        from svhdesc import loaders

        return getattr(loaders, attr)
    constants = {"URDF_PATH": "urdf_path", "MJCF_PATH": "mjcf_path", "SCENE_PATH": "scene_path"}
    if attr in constants:
        return getattr(get(DEFAULT_VARIANT), constants[attr])
    raise AttributeError(f"module 'svhdesc' has no attribute {attr!r}")
