"""The learned Q table on disk: JSON, states sorted, so the same training gives byte-identical files."""

from __future__ import annotations

import json
import math
from dataclasses import asdict, fields
from pathlib import Path

from svhdesc.errors import SvhdescError
from svhdesc.wireloop.env import ACTIONS, EnvConfig

FORMAT = "svhdesc-wireloop-q/1"


def save_policy(path: Path, q: dict[int, list[float]], config: EnvConfig, meta: dict[str, object]) -> None:
    document = {
        "format": FORMAT,
        "actions": list(ACTIONS),
        "state": "wire bits of the 5x5 square (row-major, bit 0 top-left) | objective index << 25 | rotation << 30",
        "environment": asdict(config),
        "training": meta,
        "q": [[state, values] for state, values in sorted(q.items())],
    }
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(document, indent=None, separators=(",", ":")) + "\n", encoding="utf-8")


def load_policy(path: Path) -> tuple[dict[int, list[float]], EnvConfig]:
    if not path.is_file():
        raise SvhdescError(f"{path}: no such policy file")
    try:
        document = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise SvhdescError(f"{path}: not a policy file ({exc})") from None
    if not isinstance(document, dict) or document.get("format") != FORMAT:
        raise SvhdescError(f"{path}: not a policy file (expected format '{FORMAT}')")
    known = {f.name for f in fields(EnvConfig)}
    settings = document.get("environment")
    if not isinstance(settings, dict) or set(settings) - known:
        raise SvhdescError(f"{path}: bad 'environment' section")
    try:
        config = EnvConfig(**settings)
    except (TypeError, ValueError) as exc:
        raise SvhdescError(f"{path}: bad 'environment' section ({exc})") from None
    q: dict[int, list[float]] = {}
    rows = document.get("q")
    if not isinstance(rows, list):
        raise SvhdescError(f"{path}: no 'q' table")
    for number, row in enumerate(rows):
        ok = (
            isinstance(row, list)
            and len(row) == 2
            and isinstance(row[0], int)
            and isinstance(row[1], list)
            and len(row[1]) == len(ACTIONS)
            and all(isinstance(v, (int, float)) and math.isfinite(v) for v in row[1])
        )
        if not ok:
            raise SvhdescError(f"{path}: q row {number} must be [state, [{len(ACTIONS)} finite numbers]]")
        q[row[0]] = [float(v) for v in row[1]]
    return q, config
