"""Every number in the IR must be finite before anything is written."""

from __future__ import annotations

import dataclasses
import math
from typing import Any

from svhdesc.errors import SvhdescError
from svhdesc.ir import Robot


def _first_bad(value: Any, path: str) -> str | None:
    if isinstance(value, float):
        return None if math.isfinite(value) else path
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        label = getattr(value, "name", None)
        for spec in dataclasses.fields(value):
            if spec.name == "settings":
                continue
            found = _first_bad(getattr(value, spec.name), f"{path}{f' {label}' if label else ''}.{spec.name}")
            if found:
                return found
        return None
    if isinstance(value, (tuple, list)):
        for index, item in enumerate(value):
            found = _first_bad(item, f"{path}[{index}]")
            if found:
                return found
    return None


def check_finite(robot: Robot) -> None:
    """Refuse a model holding NaN or infinity anywhere (names the field and its joint or link)."""
    bad = _first_bad(robot, "model")
    if bad:
        raise SvhdescError(f"{robot.name}: non-finite number in {bad}")
