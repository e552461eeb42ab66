"""The size of model validate's full tier simulates (``core.limits``): past it, the file is refused before anything
is compiled, naming the limit and the static tier, which reads any size (linear: 10,000 links in seconds). A file
found in a folder's walk gets that as a finding instead, so that one big model does not hide the others' findings."""

from __future__ import annotations

from pathlib import Path

from lxml import etree

from svhdesc.core.limits import MAX_SIMULATED_JOINTS, depth_problem
from svhdesc.errors import SvhdescError
from svhdesc.validate.findings import CheckResult, Finding
from svhdesc.validate.full_checks import FULL_CHECKS


def _movable(root: etree._Element) -> int:
    """The movable joints a URDF or an MJCF declares (an MJCF's defaults and includes left out)."""
    if root.tag == "robot":
        return sum(1 for joint in root.findall("joint") if joint.get("type") != "fixed")
    found = root.iterfind(".//worldbody//joint"), root.iterfind(".//worldbody//freejoint")
    return sum(1 for joints in found for _ in joints)


def too_big_to_simulate(root: etree._Element) -> str | None:
    """Why the full tier does not simulate this model (past ``MAX_SIMULATED_JOINTS`` movable joints, or a URDF tree
    deeper than ``core.limits.MAX_DEPTH``), or None."""
    movable = _movable(root)
    if movable > MAX_SIMULATED_JOINTS:
        return (
            f"{movable} movable joints, more than the {MAX_SIMULATED_JOINTS} validate's full tier simulates (its "
            "simulations grow faster than the joints); validate it with --tier static"
        )
    if root.tag != "robot":
        return None
    ends = ((j.find("parent"), j.find("child")) for j in root.findall("joint"))
    too_deep = depth_problem({c.get("link", ""): p.get("link", "") for p, c in ends if p is not None and c is not None})
    return f"{too_deep}; validate it with --tier static" if too_deep is not None else None


def unsimulated(root: etree._Element, path: Path, walked: bool, check: str) -> list[CheckResult] | None:
    """None where the full tier may simulate the model; else an SvhdescError for a file given by name, and for one
    found in a folder's walk a failing ``check`` (its compile check) with the full tier's checks skipped."""
    why = too_big_to_simulate(root)
    if why is None:
        return None
    if not walked:
        raise SvhdescError(f"{path}: {why}")
    skipped = [CheckResult(name, "skipped", reason="too big to simulate") for name in FULL_CHECKS]
    return [CheckResult(check, "fail", [Finding(check, str(path), None, why)]), *skipped]
