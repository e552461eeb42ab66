"""The hand against facts about the real SVH: the driver's fingertip forces and the grasps it is made for.

The clean figures come from the right hand's full validate run (tests/conftest.py `validated`); `validate --checks
fingertip_force,grasps` on a copy of the committed generated/svh_right with one seeded fault each: a servo weakened
to half its effort, a pinch target spoiled.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest
from lxml import etree

from svhdesc.core.settings.config import load_config
from svhdesc.core.settings.coupling import load_spec
from svhdesc.errors import SvhdescError
from tests.validate.test_validate import PREFIX, REPO, SOURCE, VARIANT, faulty_copy, one, validate_pair

pytestmark = pytest.mark.skipif(not (SOURCE / f"{VARIANT}.xml").is_file(), reason=f"{SOURCE} is not built")

GRASPS = ("power", "pinch", "tripod", "lateral", "hook")


def test_fingertip_force_matches_the_driver(validated: Callable[[str], Any]) -> None:
    """The fingertip forces of the right hand's full validate run."""
    result, checks, _ = validated(VARIANT)
    assert checks["fingertip_force"]["status"] == "pass", result.stdout + result.stderr
    figures = checks["fingertip_force"]["data"]
    # Every channel with a driver force constant; none for Thumb_Opposition and Finger_Spread.
    spec = {c.name: c for c in load_spec(REPO / "config" / "coupling.yaml").channels}
    assert set(figures) == {n for n, c in spec.items() if c.tip_force is not None} and len(figures) == 7
    for name, row in figures.items():
        assert row["driver_N"] == spec[name].tip_force
        assert abs(row["tip_force_N"] / row["driver_N"] - 1) <= 0.2, (name, row)
    assert "simulated N" in result.stdout


def _halve_servo(tree: etree._ElementTree) -> None:
    """Index_Finger_Distal's servo at half the effort its tip force was derived with."""
    servo = one(tree, f"//actuator/position[@joint='{PREFIX}_Index_Finger_Distal']")
    low, high = (float(v) for v in servo.get("forcerange").split())
    servo.set("forcerange", f"{low / 2!r} {high / 2!r}")


def test_weak_servo_fails_fingertip_force_naming_the_channel(tmp_path: Path) -> None:
    urdf, mjcf = faulty_copy(tmp_path, mjcf_edit=_halve_servo)
    result, checks = validate_pair(urdf, mjcf, tmp_path, "--checks", "fingertip_force")
    assert result.returncode == 1
    check = checks["fingertip_force"]
    assert check["status"] == "fail"
    assert "Index_Finger_Distal presses" in check["detail"]
    assert "Index_Finger_Proximal" not in check["detail"]
    row = check["data"]["Index_Finger_Distal"]
    assert row["tip_force_N"] == pytest.approx(row["driver_N"] / 2, rel=0.2)


def test_every_grasp_holds(validated: Callable[[str], Any]) -> None:
    """The grasps of the right hand's full validate run."""
    result, checks, _ = validated(VARIANT)
    assert checks["grasps"]["status"] == "pass", result.stdout
    figures = checks["grasps"]["data"]
    assert tuple(figures) == GRASPS
    for name, row in figures.items():
        assert set(row["slip_m"]) == {"out of palm", "along fingers", "towards thumb"}
        assert max(row["slip_m"].values()) < 0.005, (name, row)
        assert row["grip_force_N"] > 1.0 and row["passed"]
    assert figures["pinch"]["tip_gap_m"] < 0.001
    assert {"thumb", "index"} <= set(figures["pinch"]["contacts"])
    assert {"index", "middle", "ring", "pinky"} <= set(figures["hook"]["contacts"])
    assert "thumb" not in figures["hook"]["contacts"]


def _spoil_pinch(tree: etree._ElementTree) -> None:
    """The pinch keyframe with the index finger straight: its tip never meets the thumb's."""
    import mujoco

    model = mujoco.MjModel.from_xml_path(str(SOURCE / f"{VARIANT}.xml"))
    joint = model.joint(f"{PREFIX}_Index_Finger_Distal")
    key = one(tree, "//keyframe/key[@name='pinch']")
    for attribute, index in (("qpos", int(joint.qposadr[0])), ("ctrl", int(model.actuator(joint.name).id))):
        values = key.get(attribute).split()
        values[index] = "0"
        key.set(attribute, " ".join(values))


def test_spoiled_pinch_fails_naming_the_grasp(tmp_path: Path) -> None:
    urdf, mjcf = faulty_copy(tmp_path, mjcf_edit=_spoil_pinch)
    result, checks = validate_pair(urdf, mjcf, tmp_path, "--checks", "grasps")
    assert result.returncode == 1
    check = checks["grasps"]
    assert check["status"] == "fail"
    failed = [name for name, row in check["data"].items() if not row["passed"]]
    assert failed == ["pinch"], check["detail"]
    assert "pinch: thumb and index tips" in check["detail"]


def test_grasp_postures_reach_every_output() -> None:
    """Keyframes, so MJCF keys and SRDF group states carry them as they carry home and test."""
    srdf = etree.parse(str(SOURCE / "config" / f"{VARIANT}.srdf"))
    states = {s.get("name") for s in srdf.iter("group_state")}
    mjcf = etree.parse(str(SOURCE / f"{VARIANT}.xml"))
    keys = {k.get("name") for k in mjcf.iter("key")}
    for name in ("open", "fist", *GRASPS):
        assert name in states and name in keys


@pytest.mark.parametrize(
    "grasp, message",
    [
        ({"object": "cone", "size": [0.01], "mass": 0.1, "pos": [0, 0, 0]}, "must be one of"),
        ({"object": "sphere", "size": [0.01, 0.02], "mass": 0.1, "pos": [0, 0, 0]}, "a sphere needs 1 number"),
        ({"object": "sphere", "size": [0.01], "mass": 0.1, "pos": [0, 0, 0], "fingers": ["toe"]}, "'toe'"),
        ({"object": "sphere", "size": [0.01], "mass": 0.1}, "needs pos"),
        ({"object": "sphere", "size": [0.01], "mass": 0.1, "pos": [0, 0, 0], "grip": 1}, "unknown key"),
    ],
)
def test_bad_grasp_config_is_one_error_naming_the_line(tmp_path: Path, grasp: dict, message: str) -> None:
    import yaml

    config = tmp_path / "svhdesc.yaml"
    base = yaml.safe_load((REPO / "config" / "svhdesc.yaml").read_text())
    base["coupling"] = str(REPO / "config" / "coupling.yaml")
    base["packages"] = {"svhdesc": str(REPO)}
    base["grasps"] = {"pinch": grasp}
    for variant in base["variants"].values():
        variant["xacro"] = str((REPO / "config" / variant["xacro"]).resolve())
    config.write_text(yaml.safe_dump(base))
    with pytest.raises(SvhdescError, match=message) as error:
        load_config(config)
    assert f"{config}:" in str(error.value)


def test_tip_force_must_be_positive(tmp_path: Path) -> None:
    text = (REPO / "config" / "coupling.yaml").read_text().replace("tip_force: 4.13}", "tip_force: -4.13}")
    spec = tmp_path / "coupling.yaml"
    spec.write_text(text)
    with pytest.raises(SvhdescError, match=r"coupling.yaml:\d+.*Index_Finger_Distal: tip_force must be > 0"):
        load_spec(spec)
