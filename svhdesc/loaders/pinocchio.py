"""pinocchio (PyPI ``pin``): a RobotWrapper whose coupled joints are pinocchio mimic joints.

    robot = load_pinocchio("svh_right")   # robot.model.nq == 9 (ur5_svh_right: 15); 20 / 26 with mimic=False
    q = pinocchio.neutral(robot.model)     # channels (and arm joints) only
    robot.framesForwardKinematics(q)      # followers move as multiplier * channel + offset

pinocchio's ``mimic=True`` needs each channel parsed before its followers, and urdfdom visits sibling joints sorted
by name. So that any joint order works, the URDF pinocchio reads has its joints renamed to sort the branches that
hold a channel first (``0<name>``, else ``1<name>``), and the model gets the real names back. That URDF, with absolute
mesh paths, lives in a temporary folder removed once read: nothing is written elsewhere.
"""

from __future__ import annotations

import tempfile
from pathlib import Path
from typing import Any

from lxml import etree

from svhdesc.loaders._common import require
from svhdesc.model import get


def load_pinocchio(name: str = "ur5_svh_right", mimic: bool = True) -> Any:
    """``pinocchio.RobotWrapper`` with model, collision and visual geometry (meshes by absolute path); ``name`` a
    shipped variant or a built variant's folder."""
    pinocchio = require("pinocchio", "load_pinocchio")
    text, names = leaders_first(get(name).urdf_text("path"))
    with tempfile.TemporaryDirectory(prefix="svhdesc-pinocchio-") as tmp:
        path = Path(tmp) / "robot.urdf"
        path.write_text(text)
        robot = pinocchio.RobotWrapper.BuildFromURDF(str(path), mimic=mimic)
    model = robot.model
    for i, joint in enumerate(model.names):
        model.names[i] = names.get(joint, joint)
    for i, frame in enumerate(model.frames):
        if frame.name in names:
            frame.name = names[frame.name]
            model.frames[i] = frame
    return pinocchio.RobotWrapper(model, robot.collision_model, robot.visual_model)


def leaders_first(text: str) -> tuple[str, dict[str, str]]:
    """The URDF with every joint renamed so that, among siblings, those whose branch holds a ``<mimic>`` leader
    sort first; and the new names -> the real ones."""
    root = etree.fromstring(text.encode())
    joints = root.findall("joint")
    leaders = {tag.get("joint") for joint in joints if (tag := joint.find("mimic")) is not None}
    below: dict[str, list[etree._Element]] = {}  # link -> the joints it is the parent of
    for joint in joints:
        below.setdefault(joint.find("parent").get("link"), []).append(joint)

    def holds_leader(joint: etree._Element) -> bool:
        return joint.get("name") in leaders or any(
            holds_leader(j) for j in below.get(joint.find("child").get("link"), [])
        )

    renamed = {j.get("name"): f"{0 if holds_leader(j) else 1}{j.get('name')}" for j in joints}
    for element in root.iter("joint", "mimic"):  # <transmission>'s <joint name=> too: pinocchio ignores it
        attribute = "joint" if element.tag == "mimic" else "name"
        if element.get(attribute) in renamed:
            element.set(attribute, renamed[element.get(attribute)])
    restored = {new: old for old, new in renamed.items()}
    return etree.tostring(root, xml_declaration=True, encoding="utf-8").decode(), restored
