"""Convex decomposition of collision meshes with CoACD, behind a content-addressed cache.

Modules: ``params`` (CoACD settings, presets), ``keys`` (cache keys), ``coacd_run`` (the CoACD call and
its post-processing), ``cache`` (the on-disk cache), ``pool`` (worker processes), ``source`` (where a
build's hulls come from: committed outputs, the cache, CoACD).

CoACD is slow (tens of seconds for the vendor palm at its defaults) and every extra hull slows
the simulation, so the build decomposes each mesh once per (mesh, parameters, CoACD version) and
serves every later build from ``HullCache``.  Results are a pure function of the cache key:

* the input is canonicalised first (``meshes.stl_bytes``: float32 triangles in a canonical order,
  then identical vertices merged), so two meshes with the same key are decomposed from the same
  bytes, whatever their vertex and face order;
* CoACD runs with a fixed seed (it is reproducible on one machine, whatever its thread count);
* every part is re-hulled from float32 points, so the hull survives the STL round trip of the
  cache bit for bit, and the returned meshes are always parsed back from those bytes.
"""

from __future__ import annotations

from svhdesc.compiler.decompose.cache import CacheWarning, HullCache, cached_decompose
from svhdesc.compiler.decompose.coacd_run import _close_holes, _hull, _merge_to_cap, bounded_hull, decompose
from svhdesc.compiler.decompose.keys import cache_key
from svhdesc.compiler.decompose.params import LINK_CLASS_PARAMS, DecompParams, DecompParamsError
from svhdesc.compiler.decompose.pool import parallel_decompose
from svhdesc.core.source.meshes import mesh_from_stl as _mesh_from_stl

__all__ = [
    "CacheWarning",
    "LINK_CLASS_PARAMS",
    "DecompParams",
    "DecompParamsError",
    "HullCache",
    "bounded_hull",
    "cache_key",
    "cached_decompose",
    "decompose",
    "parallel_decompose",
    # for the tests of the internals
    "_close_holes",
    "_hull",
    "_merge_to_cap",
    "_mesh_from_stl",
]
