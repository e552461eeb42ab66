"""What every loader shares: the optional import, the URDF with absolute mesh paths, the couplings."""

from __future__ import annotations

from pathlib import Path
from types import ModuleType

from lxml import etree

from svhdesc.extras import require as _require
from svhdesc.model import Coupling, get, urdf_couplings


def require(module: str, loader: str) -> ModuleType:
    """Import an engine on first use, or raise svhdesc.extras.MissingExtra naming the pip extra."""
    return _require(module, purpose=loader)


def couplings(name: str) -> list[Coupling]:
    """The variant's coupled joints (its URDF's <mimic>: offset and multiplier), in the URDF's order."""
    return urdf_couplings(get(name).urdf_path)


def contact_excludes(name: str) -> list[tuple[str, str]]:
    """Link pairs the MJCF never collides (adjacent, or touching at rest): engines with self-collision
    on by default (Drake) need the same filter, or the fingers start in contact with the palm."""
    root = etree.parse(str(get(name).mjcf_path)).getroot()
    return [(e.get("body1"), e.get("body2")) for e in root.iter("exclude")]


def absolute_urdf(name: str) -> Path:
    """The variant's URDF with every mesh as an absolute path (pybullet, pinocchio, Drake and DART have
    no ROS package lookup); every loader gets its URDF here."""
    return get(name).absolute_urdf_path("path")
