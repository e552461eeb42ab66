"""When a fresh build of a file agrees with the committed one: the rule of ``build --check`` and the meshes' test.

Bytes equal, or, for text, everything equal except numbers, and each number within ``RTOL`` relative of its
counterpart. The build computes with CPU-independent arithmetic (``svhdesc.core.exact``), so on every machine
tried the bytes are equal; the tolerance is the safety net for a last-bit difference of a C library on a CPU nobody
tried. It is far below any real change: a number moved by 1e-9 of itself fails. The manifest's output hashes follow
the same rule: a hash may differ only for an output that agrees by it.
"""

from __future__ import annotations

import json
import re
from pathlib import Path
from typing import Any

RTOL = 1e-10  # relative; the perturbation test (SVHDESC_PERTURB_ULPS) moves written numbers by up to ~1e-12
# Every text output kind: a build on another CPU may move a written number in any of them (test_determinism checks
# that every text file under generated/ has one of these suffixes).
TEXT_SUFFIXES = {
    ".urdf",
    ".xacro",
    ".xml",
    ".srdf",
    ".yaml",
    ".launch",
    ".py",
    ".obj",
    ".dae",
    ".json",
    ".txt",
    ".usda",
}
_NUMBER = re.compile(rb"([-+]?(?:\d+\.\d*|\.\d+|\d+)(?:[eE][-+]?\d+)?)")


def numbers_agree(a: float, b: float, rtol: float = RTOL) -> bool:
    return a == b or abs(a - b) <= rtol * max(abs(a), abs(b))


def text_difference(new: bytes, old: bytes, rtol: float = RTOL) -> str | None:
    """None if the texts agree; else 'line N: OLD -> NEW' at the first place they do not."""
    if new == old:
        return None
    new_parts, old_parts = _NUMBER.split(new), _NUMBER.split(old)
    for index, (a, b) in enumerate(zip(new_parts, old_parts)):
        same = a == b if index % 2 == 0 else numbers_agree(float(a), float(b), rtol)
        if not same:
            line = b"".join(old_parts[:index]).count(b"\n") + 1
            return f"line {line}: {_show(b)} -> {_show(a)}"
    return "one file is longer" if len(new_parts) != len(old_parts) else None


def _show(part: bytes) -> str:
    text = part.decode("utf-8", "replace").strip()
    return repr(text if len(text) <= 40 else text[:37] + "...")


def file_difference(new: Path, old: Path, rtol: float = RTOL) -> str | None:
    """None if the files agree (bytes, or text by numbers within ``rtol``); else what differs."""
    new_bytes, old_bytes = new.read_bytes(), old.read_bytes()
    if new_bytes == old_bytes:
        return None
    if new.suffix.lower() not in TEXT_SUFFIXES:
        return "bytes differ"
    return text_difference(new_bytes, old_bytes, rtol)


def _values(entries: Any) -> Any:
    return sorted(json.dumps(v, sort_keys=True) for v in entries.values()) if isinstance(entries, dict) else entries


def manifest_difference(new: Path, old: Path, tolerated: set[str]) -> str | None:
    """Manifests agree when equal except for the hashes of ``tolerated`` outputs (those that agree by numbers)."""
    try:
        fresh, committed = json.loads(new.read_bytes()), json.loads(old.read_bytes())
    except ValueError:
        return "not JSON"
    for manifest in (fresh, committed):
        for entry in tolerated:
            if isinstance(manifest.get("outputs"), dict) and entry in manifest["outputs"]:
                manifest["outputs"][entry] = "agrees within the numeric tolerance"
        if tolerated and isinstance(manifest.get("sampled"), dict):
            # Their keys hash the assets' bytes, which then differ within the tolerance: the values must agree.
            manifest["sampled"] = {kind: _values(entries) for kind, entries in manifest["sampled"].items()}
    if fresh == committed:
        return None
    keys = sorted(k for k in {*fresh, *committed} if fresh.get(k) != committed.get(k))
    return f"differs in {', '.join(keys)}"
