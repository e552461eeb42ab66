"""Mesh assets of the build: name -> file bytes (visual STL, collision OBJ), plus the loaded mesh."""

from __future__ import annotations

from dataclasses import dataclass, field

import trimesh


@dataclass
class Assets:
    files: dict[str, bytes] = field(default_factory=dict)
    meshes: dict[str, trimesh.Trimesh] = field(default_factory=dict)
    # decomposition key -> hull assets of the unscaled source: the manifest records them so that
    # committed outputs can serve as the cache on a fresh clone.
    decompositions: dict[str, list[str]] = field(default_factory=dict)

    def add(self, name: str, mesh: trimesh.Trimesh, data: bytes) -> str:
        self.files[name] = data
        self.meshes[name] = mesh
        return name
