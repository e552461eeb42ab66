"""What every loader shares: the optional import, the URDF with absolute mesh paths, the couplings."""

from __future__ import annotations

import hashlib
import importlib
import tempfile
from dataclasses import dataclass
from pathlib import Path
from types import ModuleType

from lxml import etree

from .. import get
from ..errors import SvhdescError

EXTRA = "engines"


class MissingEngine(SvhdescError, ImportError):
    """A loader's engine is not installed; the message names the pip extra that installs it."""


def require(module: str, loader: str, extra: str = EXTRA) -> ModuleType:
    """Import an engine on first use, or say in one line how to install it."""
    try:
        return importlib.import_module(module)
    except ImportError:
        raise MissingEngine(f"{loader} needs {module}: pip install 'svhdesc[{extra}]'") from None


@dataclass(frozen=True)
class Coupling:
    """joint = multiplier * leader + offset (a URDF <mimic>)."""

    joint: str
    leader: str
    multiplier: float
    offset: float


def couplings(name: str) -> list[Coupling]:
    """The variant's coupled joints, in the URDF's order."""
    root = etree.parse(str(get(name).urdf_path)).getroot()
    return [
        Coupling(
            joint.get("name"),
            mimic.get("joint"),
            float(mimic.get("multiplier", "1")),
            float(mimic.get("offset", "0")),
        )
        for joint in root.iter("joint")
        if (mimic := joint.find("mimic")) is not None
    ]


def contact_excludes(name: str) -> list[tuple[str, str]]:
    """Link pairs the MJCF never collides (adjacent, or touching at rest): engines with self-collision
    on by default (Drake) need the same filter, or the fingers start in contact with the palm."""
    root = etree.parse(str(get(name).mjcf_path)).getroot()
    return [(e.get("body1"), e.get("body2")) for e in root.iter("exclude")]


def absolute_urdf(name: str) -> Path:
    """The variant's URDF with every mesh as an absolute path, for engines without ROS package lookup.

    The one place loaders get their URDF from, so that it can become the public
    ``svhdesc.get(name).absolute_urdf_path()`` once that exists. Understands relative URIs
    (``assets/x.stl``), ``package://<variant>/...`` and ``file://``. Cached by content in the temp dir.
    """
    model = get(name)
    root = etree.parse(str(model.urdf_path)).getroot()
    for mesh in root.iter("mesh"):
        mesh.set("filename", str(_mesh_path(mesh.get("filename", ""), model.name, model.directory)))
    data = etree.tostring(root, xml_declaration=True, encoding="utf-8")
    digest = hashlib.sha256(data).hexdigest()[:16]
    path = Path(tempfile.gettempdir()) / "svhdesc-urdf" / f"{name}-{digest}.urdf"
    if not path.is_file():
        path.parent.mkdir(parents=True, exist_ok=True)
        partial = path.with_suffix(f".{digest}.tmp")
        partial.write_bytes(data)
        partial.replace(path)  # atomic: parallel loaders never read a half-written file
    return path


def _mesh_path(uri: str, package: str, directory: Path) -> Path:
    if uri.startswith("file://"):
        return Path(uri[len("file://") :])
    if uri.startswith("package://"):
        owner, _, rest = uri[len("package://") :].partition("/")
        if owner != package:
            raise SvhdescError(f"{uri}: mesh of another package than {package}")
        return (directory / rest).resolve()
    return (directory / uri).resolve()
