"""The size of model validate's full tier simulates (``core.limits``): past it, the file is refused before anything
is compiled, naming the limit and the static tier, which reads any size (linear: 10,000 links in seconds)."""

from __future__ import annotations

from pathlib import Path

from lxml import etree

from svhdesc.core.limits import MAX_SIMULATED_JOINTS, depth_problem
from svhdesc.errors import SvhdescError


def _movable(root: etree._Element) -> int:
    """The movable joints a URDF or an MJCF declares (an MJCF's defaults and includes left out)."""
    if root.tag == "robot":
        return sum(1 for joint in root.findall("joint") if joint.get("type") != "fixed")
    found = root.iterfind(".//worldbody//joint"), root.iterfind(".//worldbody//freejoint")
    return sum(1 for joints in found for _ in joints)


def refuse_unsimulated(root: etree._Element, path: Path) -> None:
    """An SvhdescError where the full tier would simulate a model past ``MAX_SIMULATED_JOINTS`` movable joints, or
    a URDF tree deeper than ``core.limits.MAX_DEPTH``."""
    movable = _movable(root)
    if movable > MAX_SIMULATED_JOINTS:
        raise SvhdescError(
            f"{path}: {movable} movable joints, more than the {MAX_SIMULATED_JOINTS} validate's full tier simulates "
            "(its simulations grow faster than the joints); validate it with --tier static"
        )
    if root.tag == "robot":
        ends = ((j.find("parent"), j.find("child")) for j in root.findall("joint"))
        too_deep = depth_problem(
            {c.get("link", ""): p.get("link", "") for p, c in ends if p is not None and c is not None}
        )
        if too_deep is not None:
            raise SvhdescError(f"{path}: {too_deep}; validate it with --tier static")
