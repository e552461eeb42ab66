"""Knobs shared by the checks; the defaults are the full validation."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

from svhdesc.model import RANDOM_TARGET_SEED
from svhdesc.validate.vendor_geometry import default_vendor_meshes


@dataclass(frozen=True)
class Options:
    seed: int = RANDOM_TARGET_SEED  # the build steps every model through the simulate check's run with this seed
    samples: int = 100  # random configurations for the kinematics check
    plots: Path | None = None  # where contact-stability plots go
    # the vendor's SVH description (collision_fidelity compares collision geometry with its visual meshes)
    vendor_meshes: Path = field(default_factory=default_vendor_meshes)
