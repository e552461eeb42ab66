"""Where decomposed hulls come from: committed outputs, then the content cache, then CoACD."""

from __future__ import annotations

import hashlib
import os
import sys
import warnings
from dataclasses import dataclass, field
from pathlib import Path

import trimesh

from svhdesc.compiler.decompose.cache import CacheWarning, HullCache
from svhdesc.compiler.decompose.fit import misfit_hulls
from svhdesc.compiler.decompose.keys import cache_key
from svhdesc.compiler.decompose.params import DecompParams
from svhdesc.compiler.decompose.pool import parallel_decompose
from svhdesc.core import manifest as manifest_file
from svhdesc.core.source.meshes import stl_bytes
from svhdesc.paths import user_cache


def default_cache_dir() -> Path:
    explicit = os.environ.get("SVHDESC_CACHE")
    if explicit:
        return Path(explicit)
    return user_cache("hulls")


def _mesh(data: bytes, file_type: str = "stl") -> trimesh.Trimesh:
    # Committed collision hulls are OBJ (older outputs STL); both hold the same float32 corners.
    mesh = trimesh.load(trimesh.util.wrap_as_stream(data), file_type=file_type, process=False)
    mesh.merge_vertices(digits_vertex=12)
    return mesh


@dataclass
class HullSource:
    cache: HullCache | None
    jobs: int = 0
    force: bool = False
    progress: bool = False
    seeds: dict[str, list[tuple[str, bytes]]] = field(default_factory=dict)  # key -> (format, hull bytes)
    seeded_from: dict[str, Path] = field(default_factory=dict)  # key -> the first hull file of its seed
    results: dict[str, list[trimesh.Trimesh]] = field(default_factory=dict)
    counts: dict[str, int] = field(default_factory=lambda: {"decomposed": 0, "cached": 0, "committed": 0})

    def seed_from_outputs(self, directories: list[Path]) -> None:
        """Committed hulls act as a cache: a manifest maps each decomposition key to its asset files."""
        for directory in directories:
            manifest = manifest_file.read(directory)
            if manifest is None:
                continue
            outputs = manifest.get("outputs", {})
            for key, files in (manifest.get("decompositions") or {}).items():
                blobs = []
                if not isinstance(files, list) or not all(isinstance(name, str) for name in files):
                    continue
                for name in files:
                    path = directory / "assets" / name
                    data = path.read_bytes() if path.is_file() else None
                    if data is None or hashlib.sha256(data).hexdigest() != outputs.get(f"assets/{name}"):
                        break  # a missing or edited file is not a cache entry
                    blobs.append((path.suffix[1:].lower(), data))
                else:
                    self.seeds[key] = blobs
                    self.seeded_from[key] = directory / "assets" / files[0]

    def _seeded(self, key: str, mesh: trimesh.Trimesh) -> list[trimesh.Trimesh] | None:
        """Committed hulls for ``key`` that pass the hull cache's own check against ``mesh`` (``fit``): a file that
        does not parse, or hulls that cannot be a decomposition of the mesh (edited with their manifest entry), are
        one warning and decomposed again."""
        if key not in self.seeds:
            return None
        try:
            hulls = [_mesh(b, kind) for kind, b in self.seeds[key]]
        except Exception:  # any parser failure: decompose again
            hulls = None
        misfit = "a hull does not parse" if hulls is None else misfit_hulls(mesh, hulls)
        if misfit:
            first = self.seeded_from[key]
            message = f"hulls {first} and the rest of its decomposition: {misfit}; decomposing again"
            warnings.warn(message, CacheWarning, stacklevel=3)
            del self.seeds[key]
            return None
        return hulls

    def prefetch(self, jobs: list[tuple[str, trimesh.Trimesh, DecompParams]]) -> None:
        """Decompose every job not yet known, in parallel; later ``get`` calls are lookups."""
        todo = []
        for _name, mesh, params in jobs:
            key = cache_key(mesh, params)
            if key in self.results:
                continue
            seeded = self._seeded(key, mesh) if not self.force else None
            if seeded is not None:
                self.results[key] = seeded
                self.counts["committed"] += 1
            else:
                todo.append((key, mesh, params))
        unique = {key: (key, mesh, params) for key, mesh, params in todo}
        done = parallel_decompose(
            list(unique.values()), self.cache, self.jobs, self.force, self.progress and sys.stderr.isatty()
        )
        for key, (hulls, hit) in done.items():
            self.results[key] = hulls
            self.counts["cached" if hit else "decomposed"] += 1

    def get(self, mesh: trimesh.Trimesh, params: DecompParams) -> tuple[str, list[trimesh.Trimesh]]:
        key = cache_key(mesh, params)
        if key not in self.results:
            self.prefetch([(key, mesh, params)])
        return key, self.results[key]


def hull_bytes(hulls: list[trimesh.Trimesh]) -> list[bytes]:
    return [stl_bytes(h) for h in hulls]
