"""Knobs shared by the checks; the defaults are the full validation."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path


@dataclass(frozen=True)
class Options:
    seed: int = 0
    samples: int = 100  # random configurations for the kinematics check
    plots: Path | None = None  # where contact-stability plots go
