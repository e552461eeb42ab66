"""The MJCF's default classes: a person editing it by hand changes a gain or a damping in one place."""

from __future__ import annotations

import shutil

import mujoco
import pytest
from lxml import etree

import svhdesc
from svhdesc.core.settings.config import load_config
from svhdesc.paths import default_config
from tests.support import VARIANTS


def _classes(root: etree._Element) -> dict[str, etree._Element]:
    return {d.get("class"): d for d in root.iter("default") if d.get("class")}


@pytest.mark.parametrize("variant", VARIANTS)
def test_servo_gain_and_drive_damping_are_written_once(variant: str) -> None:
    root = etree.parse(str(svhdesc.get(variant).mjcf_path)).getroot()
    settings = load_config(default_config()).variants[variant].settings
    servo = _classes(root)["servo"].find("position")
    assert float(servo.get("kp")) == settings.hand.kp
    drive = _classes(root)["drive"].find("joint")
    assert float(drive.get("damping")) == settings.hand.joint_damping
    hand = [a for a in root.find("actuator") if a.get("class") == "servo"]
    assert len(hand) == 9 and all(a.get("kp") is None and a.get("dampratio") is None for a in hand)
    joints = root.find("worldbody").iter("joint")
    assert all(j.get("damping") is None for j in joints if j.get("class") in ("drive", "coupled", "arm"))


def test_editing_a_class_changes_every_member(tmp_path) -> None:  # type: ignore[no-untyped-def]
    model = svhdesc.get("ur5_svh_right")
    copy = tmp_path / model.name
    shutil.copytree(model.directory, copy)
    tree = etree.parse(str(copy / model.mjcf_path.name))
    classes = _classes(tree.getroot())
    classes["servo"].find("position").set("kp", "42")
    classes["wrist"].find("position").set("kp", "123")
    tree.write(str(copy / model.mjcf_path.name))
    compiled = mujoco.MjModel.from_xml_path(str(copy / model.mjcf_path.name))
    original = svhdesc.load_mujoco("ur5_svh_right")
    for a in range(compiled.nu):
        name = compiled.actuator(a).name
        expected = 42.0 if "_hand_" in name else 123.0 if name.startswith("wrist") else original.actuator_gainprm[a, 0]
        assert compiled.actuator_gainprm[a, 0] == expected, name
