"""Cache keys: a decomposition is a pure function of (canonical mesh bytes, parameters, CoACD version)."""

from __future__ import annotations

import hashlib
import importlib.metadata

import trimesh

from svhdesc.compiler.decompose.params import DecompParams
from svhdesc.core.source.meshes import stl_bytes

# Bump when anything in the post-processing changes its output: it is part of every key,
# so stale cache entries simply stop matching.
_ALGORITHM_VERSION = "svhdesc.decompose/1"


def cache_key(mesh: trimesh.Trimesh, params: DecompParams) -> str:
    """sha256 over the input's canonical STL, the params' canonical JSON and the CoACD version."""
    return _key_from_stl(stl_bytes(mesh), params)


def _key_from_stl(stl: bytes, params: DecompParams) -> str:
    h = hashlib.sha256()
    # Length-prefixed fields, so no two different inputs can concatenate to the same stream.
    for part in (_ALGORITHM_VERSION.encode(), _coacd_version().encode(), params.to_json().encode(), stl):
        h.update(len(part).to_bytes(8, "little"))
        h.update(part)
    return h.hexdigest()


def _coacd_version() -> str:
    try:
        return importlib.metadata.version("coacd")
    except importlib.metadata.PackageNotFoundError:
        return "unknown"
