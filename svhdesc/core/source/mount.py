"""A config's ``mount``: this project's SVH grafted onto an arm read from any URDF or xacro, in the IR.

The hand is expanded from ``xacro/svh_mount.urdf.xacro`` with the mount's side, prefix, parent link and origin, so its
fixed joint to the arm is the one a hand-written xacro would have; the arm is the variant's own source, less the
subtrees ``mount.remove`` names (its own gripper). Composing in the IR keeps both sources unedited and any format
the reader takes.
"""

from __future__ import annotations

from pathlib import Path

from svhdesc.core.settings.schema import Mount
from svhdesc.errors import SvhdescError
from svhdesc.ir import Robot
from svhdesc.paths import source_root

HAND_XACRO = Path("xacro") / "svh_mount.urdf.xacro"
HAND_PACKAGE = "svhdesc"  # the hand's meshes and macros: package://svhdesc/...


def hand_xacro() -> Path:
    return source_root() / HAND_XACRO


def hand_packages(packages: dict[str, Path]) -> dict[str, Path]:
    """The package map with this project's own (the config's entry, if it has one, wins)."""
    return {HAND_PACKAGE: source_root(), **packages}


def hand_args(mount: Mount, prefix: str) -> dict[str, str]:
    def vector(values: list[float]) -> str:
        return " ".join(repr(float(v)) for v in values)

    return {
        "side": mount.side,
        "prefix": prefix,
        "parent": mount.parent,
        "xyz": vector(mount.xyz),
        "rpy": vector(mount.rpy),
    }


def without(robot: Robot, mount: Mount) -> Robot:
    """The arm less every link at or below a link of ``mount.remove``."""
    names = {link.name for link in robot.links}
    gone: set[str] = set()
    for name in mount.remove:
        if name not in names:
            raise SvhdescError(f"{mount.at('remove')}: mount.remove: the arm has no link {name}")
        if name == robot.root:
            raise SvhdescError(f"{mount.at('remove')}: mount.remove: {name} is the arm's root")
        stack = [name]
        while stack:
            link = stack.pop()
            gone.add(link)
            stack += [j.child for j in robot.child_joints(link)]
    links = tuple(link for link in robot.links if link.name not in gone)
    joints = tuple(j for j in robot.joints if j.child not in gone)
    return Robot(robot.name, links, joints, robot.root)


def graft(arm: Robot, hand: Robot, mount: Mount) -> Robot:
    """The arm (less ``mount.remove``) with the hand's tree hung from ``mount.parent``; ``hand``'s root is a stand-in
    link of that name."""
    source = {link.name for link in arm.links}
    arm = without(arm, mount)
    names = {link.name for link in arm.links}
    if mount.parent not in names:
        removed = " once mount.remove has taken its links" if mount.parent in source else ""
        raise SvhdescError(f"{mount.at('parent')}: mount.parent: the arm has no link {mount.parent}{removed}")
    links = tuple(link for link in hand.links if link.name != hand.root)
    for kind, mine, theirs in (
        ("link", [link.name for link in links], names),
        ("joint", [j.name for j in hand.joints], {j.name for j in arm.joints}),
    ):
        clash = next((name for name in mine if name in theirs), None)
        if clash is not None:
            raise SvhdescError(f"{mount.at('prefix')}: the hand's {kind} {clash} is also the arm's: set mount.prefix")
    return Robot(arm.name, (*arm.links, *links), (*arm.joints, *hand.joints), arm.root)
