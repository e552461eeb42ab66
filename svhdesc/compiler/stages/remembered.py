"""Results a build samples in MuJoCo (batch capacities, the MoveIt collision matrix), remembered by content.

Like the hulls: the same model, assets and sampling plan give the same result, so only a changed model is stepped
again. A key hashes every input; an entry is one JSON file written atomically; an unreadable entry is a miss and an
unwritable cache costs the next build the sampling, nothing else. ``SVHDESC_CACHE`` moves it with the hulls.
"""

from __future__ import annotations

import hashlib
import json
import os
import tempfile
from collections.abc import Callable, Iterable
from pathlib import Path
from typing import Any, TypeVar

from svhdesc.compiler.decompose.source import default_cache_dir

T = TypeVar("T")


def cache_dir(kind: str) -> Path:
    return default_cache_dir() / kind


def content_key(parts: Iterable[bytes], assets: dict[str, bytes]) -> str:
    """sha256 over each part and each asset (name and bytes), with MuJoCo's version: what the result depends on."""
    import mujoco

    digest = hashlib.sha256(mujoco.__version__.encode())
    for part in parts:
        digest.update(hashlib.sha256(part).digest())
    for name in sorted(assets):
        digest.update(name.encode() + hashlib.sha256(assets[name]).digest())
    return digest.hexdigest()


def remembered(
    cache: Path, key: str, compute: Callable[[], T], encode: Callable[[T], Any], decode: Callable[[Any], T]
) -> T:
    entry = cache / f"{key}.json"
    try:
        return decode(json.loads(entry.read_text()))
    except (OSError, ValueError, TypeError, KeyError):
        pass
    result = compute()
    try:
        cache.mkdir(parents=True, exist_ok=True)
        with tempfile.NamedTemporaryFile("w", dir=cache, suffix=".tmp", delete=False) as handle:
            json.dump(encode(result), handle)
        os.replace(handle.name, entry)  # a reader sees a whole entry or none
    except OSError:
        pass
    return result
