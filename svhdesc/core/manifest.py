"""``manifest.json``, the one record of a built variant: every input, output, decomposition and tool by hash, and
the results the build sampled in MuJoCo (``sampled``, keyed by content: svhdesc.compiler.probes.cache).

The build writes it; freshness, hull seeding and the validator read it, all through here. A manifest
that is missing, unreadable or not shaped like one reads as None (the variant is then rebuilt).
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

FILE = "manifest.json"
_MAPPINGS = ("inputs", "outputs", "decompositions", "sampled", "tools")


def path(directory: Path) -> Path:
    return directory / FILE


def write(directory: Path, manifest: dict[str, Any]) -> None:
    path(directory).write_text(json.dumps(manifest, indent=2, sort_keys=True) + "\n")


def read(directory: Path) -> dict[str, Any] | None:
    try:
        data = json.loads(path(directory).read_text(encoding="utf-8"))
    except (OSError, ValueError):  # UnicodeDecodeError and JSONDecodeError are ValueErrors
        return None
    if not isinstance(data, dict) or not all(isinstance(data.get(key, {}), dict) for key in _MAPPINGS):
        return None
    return data
