"""The content-addressed hull cache on disk, and ``decompose`` through it."""

from __future__ import annotations

import dataclasses
import hashlib
import json
import os
import shutil
import tempfile
import warnings
from collections import Counter
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import trimesh

from svhdesc.compiler.decompose.coacd_run import _decompose_stl
from svhdesc.compiler.decompose.fit import misfit_hulls
from svhdesc.compiler.decompose.keys import _ALGORITHM_VERSION, _coacd_version, _key_from_stl, cache_key
from svhdesc.compiler.decompose.params import DecompParams
from svhdesc.core.source.meshes import mesh_from_stl, stl_bytes

# --------------------------------------------------------------------------- cache


class CacheWarning(UserWarning):
    """A cache entry failed its check and is rebuilt."""


class HullCache:
    """Content-addressed store: ``<root>/<key>/hull_000.stl ... entry.json``.

    Entries are written into a temporary sibling directory and renamed into place, so readers
    never see a half-written entry; anything that fails validation later (truncated file, edited
    JSON, missing hull, e.g. after a crash before the data hit the disk) is deleted and reported
    as a miss, so no fsync is needed for correctness.
    """

    ENTRY = "entry.json"
    FORMAT = 1

    def __init__(self, root: Path | str) -> None:
        self.root = Path(root)
        self.broken = ""  # why writing failed: a cache that cannot be written is not used for writing again

    def store(self, key: str, hull_stl_bytes: list[bytes], meta: Mapping[str, Any] | None = None) -> None:
        """``put`` for a build: a read-only, full or misplaced cache warns once and the build goes on."""
        if self.broken:
            return
        try:
            self.put(key, hull_stl_bytes, meta)
        except OSError as exc:
            self.broken = exc.strerror or type(exc).__name__
            warnings.warn(f"hull cache {self.root} is unusable ({self.broken}); building without caching", stacklevel=2)

    def meshes(self, key: str) -> list[trimesh.Trimesh] | None:
        """The entry parsed into meshes, or None; an entry that does not parse is deleted (rebuilt)."""
        try:
            blobs = self.get(key)
        except OSError:
            return None
        if blobs is None:
            return None
        try:
            return [mesh_from_stl(b) for b in blobs]
        except ValueError:
            problem = f"hull cache entry {self.path(key)}: a hull does not parse; decomposing again"
            warnings.warn(problem, CacheWarning, stacklevel=2)
            shutil.rmtree(self.path(key), ignore_errors=True)
            return None

    def hulls_for(self, key: str, mesh: trimesh.Trimesh) -> list[trimesh.Trimesh] | None:
        """``meshes(key)`` if they can be a decomposition of ``mesh`` (``fit.misfit_hulls``); an entry that cannot
        is dropped, with a warning."""
        hulls = self.meshes(key)
        misfit = misfit_hulls(mesh, hulls) if hulls is not None else ""
        if not misfit:
            return hulls
        warnings.warn(f"hull cache entry {self.path(key)}: {misfit}; decomposing again", CacheWarning, stacklevel=2)
        shutil.rmtree(self.path(key), ignore_errors=True)
        return None

    @staticmethod
    def key(mesh: trimesh.Trimesh, params: DecompParams) -> str:
        return cache_key(mesh, params)

    def path(self, key: str) -> Path:
        # Keys are sha256 hex digests; anything else could escape root.
        if len(key) != 64 or any(c not in "0123456789abcdef" for c in key):
            raise ValueError(f"invalid cache key {key!r}")
        return self.root / key

    @staticmethod
    def _name(i: int) -> str:
        return f"hull_{i:03d}.stl"

    def get(self, key: str) -> list[bytes] | None:
        """The entry's hull STL bytes, or None on a miss.

        An entry that fails its check (another key's entry, a file whose digest differs, a missing or an extra
        file, unreadable JSON) is one warning, and is deleted so that it is rebuilt: never used.
        """
        entry = self.path(key)
        if not entry.is_dir():
            return None
        blobs, problem = self._read_valid(entry, key)
        if blobs is None:
            warnings.warn(f"hull cache entry {entry}: {problem}; decomposing again", CacheWarning, stacklevel=2)
            shutil.rmtree(entry, ignore_errors=True)
        return blobs

    def _read_valid(self, entry: Path, key: str) -> tuple[list[bytes] | None, str]:
        """(the hull bytes, "") or (None, what is wrong with the entry)."""
        try:
            meta = json.loads((entry / self.ENTRY).read_text(encoding="utf-8"))
            files, count = meta["files"], meta["count"]
        except (OSError, ValueError, KeyError, TypeError) as exc:  # JSONDecodeError: ValueError
            return None, f"unreadable {self.ENTRY} ({type(exc).__name__})"
        if meta.get("format") != self.FORMAT or not isinstance(count, int) or count < 1:
            return None, f"{self.ENTRY} is not of format {self.FORMAT}"
        if meta.get("key") != key:
            return None, f"it holds the entry of another key ({str(meta.get('key'))[:16]}...)"
        if not isinstance(files, list) or len(files) != count:
            return None, f"{self.ENTRY} lists {len(files) if isinstance(files, list) else 'no'} files for {count}"
        expected = {self._name(i) for i in range(count)} | {self.ENTRY}
        present = {p.name for p in entry.iterdir()}
        if present - expected:
            return None, f"extra file(s) {sorted(present - expected)}"
        blobs = []
        for i, item in enumerate(files):
            name = self._name(i)
            if not isinstance(item, dict) or item.get("name") != name:
                return None, f"{self.ENTRY} misnames hull {i}"
            try:
                data = (entry / name).read_bytes()
            except OSError:
                return None, f"missing file {name}"
            if hashlib.sha256(data).hexdigest() != item.get("sha256"):
                return None, f"{name} does not match its digest"
            blobs.append(data)
        return blobs, ""

    def put(self, key: str, hull_stl_bytes: list[bytes], meta: Mapping[str, Any] | None = None) -> Path:
        """Store (or replace) an entry atomically; ``meta`` is kept in entry.json for humans."""
        if not hull_stl_bytes:
            raise ValueError("refusing to cache an empty hull list")
        final = self.path(key)
        self.root.mkdir(parents=True, exist_ok=True)
        tmp = Path(tempfile.mkdtemp(prefix=f".{key[:16]}.", suffix=".tmp", dir=self.root))
        try:
            files = []
            for i, data in enumerate(hull_stl_bytes):
                (tmp / self._name(i)).write_bytes(data)
                files.append({"name": self._name(i), "sha256": hashlib.sha256(data).hexdigest()})
            entry = {"format": self.FORMAT, "key": key, "count": len(files), "files": files}
            if meta:
                entry["meta"] = dict(meta)
            (tmp / self.ENTRY).write_text(json.dumps(entry, indent=1, sort_keys=True) + "\n", encoding="utf-8")
            try:
                os.replace(tmp, final)
            except OSError:
                # POSIX cannot rename onto a non-empty directory: move the old entry aside first.
                # A reader in between sees no entry (a miss), never a mix of old and new files.
                trash = Path(tempfile.mkdtemp(prefix=f".{key[:16]}.", suffix=".old", dir=self.root))
                try:
                    os.replace(final, trash / "entry")
                except FileNotFoundError:
                    pass  # a concurrent get() deleted it meanwhile
                os.replace(tmp, final)
                shutil.rmtree(trash, ignore_errors=True)
        except BaseException:
            shutil.rmtree(tmp, ignore_errors=True)
            raise
        return final


def _entry_meta(params: DecompParams) -> dict[str, Any]:
    return {
        "params": dataclasses.asdict(params),
        "coacd": _coacd_version(),
        "algorithm": _ALGORITHM_VERSION,
    }


def cached_decompose(
    mesh: trimesh.Trimesh,
    params: DecompParams,
    cache: HullCache | None,
    force: bool = False,
    stats: Counter[str] | None = None,
) -> tuple[list[trimesh.Trimesh], bool]:
    """``decompose`` through the cache: (hulls, cache_hit).  ``force`` recomputes and overwrites.

    Hits and misses return identical meshes: both are parsed from the same STL bytes. ``stats``
    (the caller's counter) gets ``decomposed`` += 1 for every CoACD run.
    """
    stl = stl_bytes(mesh)
    key = _key_from_stl(stl, params)
    if cache is not None and not force:
        hit = cache.hulls_for(key, mesh)
        if hit is not None:
            return hit, True
    if stats is not None:
        stats["decomposed"] += 1
    blobs = _decompose_stl(stl, params)
    if cache is not None:
        cache.store(key, blobs, _entry_meta(params))
    return [mesh_from_stl(b) for b in blobs], False
