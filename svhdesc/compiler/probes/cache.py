"""Results a build samples in MuJoCo (batch capacities, the MoveIt collision matrix), remembered by content.

Like the hulls: the same model, assets and sampling plan give the same result, so only a changed model is stepped
again. A key hashes every input; an entry is one JSON file written atomically; an unreadable entry is a miss and an
unwritable cache costs the next build the sampling, nothing else. ``SVHDESC_CACHE`` moves it with the hulls.

Like the committed hulls, the results a built variant used are in its manifest (``sampled``: kind -> key -> value),
and a build reads those of the shipped and its own outputs before the cache (``seeded``), so a fresh clone builds
the committed models without stepping them; ``build --check`` trusts neither.
"""

from __future__ import annotations

import hashlib
import json
import os
import tempfile
import warnings
from collections.abc import Callable, Iterable, Iterator, Mapping
from contextlib import contextmanager
from contextvars import ContextVar
from pathlib import Path
from typing import Any, TypeVar

from svhdesc.compiler.decompose.source import default_cache_dir

T = TypeVar("T")

# Set while a build trusts no cached result (``build --check`` without ``--trust-cache``): every result is computed
# again and replaces its entry, as the hulls are decomposed again.
RECOMPUTE: ContextVar[bool] = ContextVar("recompute", default=False)
# Results from built variants' manifests, read before the cache (kind -> key -> encoded value).
SEEDS: ContextVar[Mapping[str, Mapping[str, Any]] | None] = ContextVar("seeds", default=None)
# Set while a variant is built: every result it uses, computed or read, for its manifest.
RECORD: ContextVar[dict[str, dict[str, Any]] | None] = ContextVar("record", default=None)


@contextmanager
def recomputing(enabled: bool = True) -> Iterator[None]:
    token = RECOMPUTE.set(enabled)
    try:
        yield
    finally:
        RECOMPUTE.reset(token)


@contextmanager
def seeded(entries: Mapping[str, Mapping[str, Any]]) -> Iterator[None]:
    token = SEEDS.set(entries)
    try:
        yield
    finally:
        SEEDS.reset(token)


@contextmanager
def recording() -> Iterator[dict[str, dict[str, Any]]]:
    """The results used while the block runs (kind -> key -> encoded value): a variant's manifest ``sampled``."""
    used: dict[str, dict[str, Any]] = {}
    token = RECORD.set(used)
    try:
        yield used
    finally:
        RECORD.reset(token)


def committed_results(manifests: Iterable[Mapping[str, Any]]) -> dict[str, dict[str, Any]]:
    """The ``sampled`` results of built variants' manifests, merged by kind (a malformed section is no seed)."""
    merged: dict[str, dict[str, Any]] = {}
    for manifest in manifests:
        for kind, entries in (manifest.get("sampled") or {}).items():
            if isinstance(entries, dict):
                merged.setdefault(kind, {}).update(entries)
    return merged


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
    """``compute()``'s result, from a committed manifest's ``sampled`` (``seeded``) or else from the entry ``key``
    when it holds one that passes its check (neither while ``recomputing``); the cache folder's name is the kind.

    An entry names its key and carries the digest of its value: another key's entry (a copied file) or an edited
    value is one warning and is computed again, never used.
    """
    entry, kind = cache / f"{key}.json", cache.name
    found, origin = None, f"cache entry {entry}"
    if not RECOMPUTE.get():
        found = (SEEDS.get() or {}).get(kind, {}).get(key)
        if found is None:
            found = _read(entry, key)
        else:
            origin = f"the committed {kind} result {key[:16]}..."
    if found is not None:
        try:
            result = decode(found)
        except (ValueError, TypeError, KeyError, IndexError):
            warnings.warn(f"{origin}: its value does not decode; computing it again", stacklevel=2)
        else:
            _record(kind, key, found)
            return result
    result = compute()
    value = encode(result)
    _record(kind, key, value)
    document = {"key": key, "sha256": _digest(value), "value": value}
    try:
        cache.mkdir(parents=True, exist_ok=True)
        with tempfile.NamedTemporaryFile("w", dir=cache, suffix=".tmp", delete=False) as handle:
            json.dump(document, handle)
        os.replace(handle.name, entry)  # a reader sees a whole entry or none
    except OSError:
        pass
    return result


def _record(kind: str, key: str, value: Any) -> None:
    used = RECORD.get()
    if used is not None:
        used.setdefault(kind, {})[key] = value


def _digest(value: Any) -> str:
    return hashlib.sha256(json.dumps(value, sort_keys=True).encode()).hexdigest()


def _read(entry: Path, key: str) -> Any:
    """The entry's value, or None: missing (silently) or failing its check (with a warning)."""
    try:
        document = json.loads(entry.read_text())
    except (FileNotFoundError, NotADirectoryError):  # no entry, or no cache folder: a plain miss
        return None
    except (OSError, ValueError) as exc:
        problem = f"unreadable ({type(exc).__name__})"
    else:
        if not isinstance(document, dict) or "value" not in document:
            problem = "not an entry of this version"
        elif document.get("key") != key:
            problem = f"it holds the entry of another key ({str(document.get('key'))[:16]}...)"
        elif document.get("sha256") != _digest(document["value"]):
            problem = "its value does not match its digest"
        else:
            return document["value"]
    warnings.warn(f"cache entry {entry}: {problem}; computing it again", stacklevel=3)
    return None
