"""A config's ``mount``: the SVH grafted onto an arm read from its own source, with no xacro written per arm.

The shipped ur5_svh_right is the UR5 with the hand on tool0 written by hand in xacro (xacro/ur5_svh.urdf.xacro);
the same arm alone plus a ``mount`` reads to the same robot, link for link and joint for joint. Then each way a
mount can be wrong gives one ``error:`` line naming the key.
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import pytest

from svhdesc.compiler.pipeline.steps import read_source
from svhdesc.compiler.pipeline.timings import Timings
from svhdesc.core.settings.config import load_config
from svhdesc.core.settings.schema import Mount
from svhdesc.core.source.mount import graft
from svhdesc.errors import SvhdescError
from svhdesc.ir import Joint, Link, Robot
from tests.support import REPO, fails_cleanly

# The project's UR5 alone, as xacro/ur5_svh.urdf.xacro has it before the hand.
ARM = """\
<?xml version="1.0"?>
<robot name="ur5" xmlns:xacro="http://www.ros.org/wiki/xacro">
  <xacro:include filename="$(find svhdesc)/xacro/ur5.xacro"/>
  <link name="world"/>
  <joint name="world_joint" type="fixed">
    <parent link="world"/>
    <child link="base_link"/>
    <origin xyz="0 0 0" rpy="0 0 0"/>
  </joint>
  <xacro:ur5_arm/>
</robot>
"""
CONFIG = """\
extends: {base}
mount: {{parent: tool0, xyz: [0, 0, 0.032], side: right}}
arm: {{enabled: true}}
variants:
  ur5_svh_right:
    xacro: arm.urdf.xacro
"""


def write(tmp_path: Path, mount: str = "{parent: tool0, xyz: [0, 0, 0.032], side: right}", extra: str = "") -> Path:
    (tmp_path / "arm.urdf.xacro").write_text(ARM)
    config = CONFIG.format(base=REPO / "config" / "svhdesc.yaml").replace(
        "mount: {parent: tool0, xyz: [0, 0, 0.032], side: right}", f"mount: {mount}"
    )
    (tmp_path / "arm.yaml").write_text(config + extra)
    return tmp_path / "arm.yaml"


def read(config: Path, name: str) -> Robot:
    variant = load_config(config).variants[name]
    packages = {"svhdesc": REPO, **variant.packages()}
    return read_source(variant, packages, Timings()).robot


def plain(robot: Robot) -> tuple[list, list, str]:
    """Links and joints as sets would compare them, less where each joint was written."""
    joints = sorted((replace(j, source="") for j in robot.joints), key=lambda j: j.name)
    return sorted(robot.links, key=lambda link: link.name), joints, robot.root


def test_a_mounted_hand_reads_as_the_hand_written_xacro(tmp_path: Path) -> None:
    """Seeded faults: hand_args without the mount's xyz (the hand at tool0 itself), or graft keeping the stand-in
    root link, make the robots differ."""
    mounted = read(write(tmp_path), "ur5_svh_right")
    shipped = read(REPO / "config" / "svhdesc.yaml", "ur5_svh_right")
    assert plain(mounted) == plain(shipped)
    assert mounted.joint("right_hand_base_joint").origin.xyz == (0.0, 0.0, 0.032)
    assert len(mounted.links) == len(shipped.links) == len({link.name for link in mounted.links})


def test_remove_drops_a_subtree_and_a_left_hand_takes_its_prefix(tmp_path: Path) -> None:
    config = write(tmp_path, "{parent: wrist_3_link, side: left, prefix: left_hand, remove: [flange]}")
    robot = read(config, "ur5_svh_right")
    names = {link.name for link in robot.links}
    assert {"flange", "tool0"}.isdisjoint(names) and "left_hand_base_link" in names
    assert robot.joint("left_hand_base_joint").parent == "wrist_3_link"
    assert not any(name.startswith("right_hand") for name in names)


@pytest.mark.parametrize(
    ("mount", "extra", "match"),
    [
        ("{parent: nowhere}", "", "mount.parent: the arm has no link nowhere"),
        ("{parent: tool0, remove: [flange]}", "", "the arm has no link tool0 once mount.remove has taken its links"),
        ("{parent: tool0, remove: [nothing]}", "", "mount.remove: the arm has no link nothing"),
        ("{parent: tool0, remove: [world]}", "", "mount.remove: world is the arm's root"),
        ("{parent: tool0, side: left}", "", "mount.side is left, but the hand's prefix is 'right_hand'"),
        ("{xyz: [0, 0, 1]}", "", "'mount.parent' is required"),
        ("{parent: tool0, side: up}", "", "must be one of ['right', 'left']"),
        ("{parent: tool0, xyz: [0, 0]}", "", "mount.xyz must have 3 numbers"),
        ("{parent: tool0, height: 1}", "", "unknown key(s) ['height'] in 'mount'"),
    ],
)
def test_a_wrong_mount_names_its_key(tmp_path: Path, mount: str, extra: str, match: str) -> None:
    config = write(tmp_path, mount, extra)
    out = tmp_path / "out"
    fails_cleanly(
        None, "build", "--config", str(config), "--out", str(out), "--package", f"svhdesc={REPO}", match=match
    )
    assert not out.exists()


def test_a_hand_named_like_the_arm_is_refused() -> None:
    arm = Robot("arm", (Link("base"), Link("x_a")), (Joint("j", "fixed", "base", "x_a"),), "base")
    hand = Robot("hand", (Link("base"), Link("x_a")), (Joint("x_j", "fixed", "base", "x_a"),), "base")
    with pytest.raises(SvhdescError, match="the hand's link x_a is also the arm's: set mount.prefix"):
        graft(arm, hand, Mount(parent="base", prefix="x"))
    joint = (Link("base"), Link("x_b"))
    with pytest.raises(SvhdescError, match="the hand's joint j is also the arm's"):
        graft(arm, Robot("hand", joint, (Joint("j", "fixed", "base", "x_b"),), "base"), Mount(parent="base"))
    grafted = graft(arm, Robot("hand", joint, (Joint("x_j", "fixed", "base", "x_b"),), "base"), Mount(parent="base"))
    assert [link.name for link in grafted.links] == ["base", "x_a", "x_b"] and grafted.root == "base"
