"""range_of_motion, settle's floor and velocity_tracking on robot files as they stand (`svhdesc validate PATH`, full
tier), the settings' keyframe and joints' quirks, and a xacro including a FIFO.

Clean robots: the three-joint arm with a sliding finger of tests/data/arm3 (an MJCF), and example-robot-data's PR2
gripper (its palm and fingers, read where pip put the package; the copy written to tmp_path is pruned to them), whose
fingertips meet before the lower end of its range: a pass with the closing pose, not a blocked joint (the issue's
third false alarm), and a two-finger gripper on its own, each finger on its own servo, whose fingers meet (the same,
its palm the fixed base). Seeded faults: a servo range past its joint's limit, which it drives the joint through
(a finding at the joint's line);
the arm's post moved into its way (a note naming the pose and the pair); a keyframe name the model lacks, a joint
the settings name that the model lacks, an effort that is not > 0 (each one error, exit 2); a weak shoulder whose
settings' effort rates it (gravity_hold passes then); a xacro including a FIFO (one error, exit 2, no hang); a
floating robot whose geoms collide with nothing (it falls through its floor: settle); a wheel's velocity servo
against damping as large as its gain (velocity_tracking, 50 % slow).
"""

from __future__ import annotations

import os
import subprocess
from pathlib import Path

import pytest
from lxml import etree

from svhdesc.errors import SvhdescError
from svhdesc.validate.files import validate_file
from svhdesc.validate.findings import FileReport
from svhdesc.validate.quirks import JointSettings, Quirks
from tests.support import REPO, run_cli

ARM = REPO / "tests" / "data" / "arm3" / "arm3.xml"
FULL = {"range_of_motion", "settle", "gravity_hold", "mujoco_compile", "mjcf_compile"}


def _erd() -> Path:
    import pybullet_data

    return Path(pybullet_data.__file__).resolve().parents[1] / "cmeel.prefix" / "share" / "example-robot-data"


def _arm(tmp_path: Path, edit=None) -> Path:  # type: ignore[no-untyped-def]
    tree = etree.parse(str(ARM))
    if edit is not None:
        edit(tree)
    path = tmp_path / "arm3.xml"
    tree.write(str(path))
    return path


def _check(report: FileReport, name: str = "range_of_motion"):  # type: ignore[no-untyped-def]
    return next(c for c in report.checks if c.name == name)


def test_the_clean_arm_reaches_every_end_and_costs_two_strokes(tmp_path: Path) -> None:
    check = _check(validate_file(_arm(tmp_path), FULL, {}, tier="full"))
    assert check.status == "pass" and check.figure.startswith("4 joint(s) driven to both ends at once"), check


def test_a_servo_driving_its_joint_through_its_limit_is_a_finding_at_the_joint(tmp_path: Path) -> None:
    """Seeded fault: the finger's servo may aim at 0.1 m on a slide that stops at 0.04 m; its 20 N push takes the
    finger 6.7 mm through MuJoCo's soft limit (actuator_ranges names the ctrlrange; range_of_motion what it does).
    Its ctrlrange as written, 0 .. 0.04 m, reaches both ends (the clean arm above)."""
    path = _arm(tmp_path, lambda t: t.find(".//position[@name='finger_slide']").set("ctrlrange", "0 0.1"))
    check = _check(validate_file(path, FULL, {}, tier="full"))
    assert check.status == "fail", check
    (finding,) = check.findings
    assert finding.message.startswith("joint 'finger_slide' goes through its limit to 0.04"), finding
    assert "driven to its upper end 0.04 m from keyframe 'home', nothing in contact" in finding.message
    assert finding.line == etree.parse(str(path)).find(".//joint[@name='finger_slide']").sourceline


def test_a_joint_stopped_short_is_reported_with_the_pose_and_the_pair(tmp_path: Path) -> None:
    """The post moved under the arm: the shoulder stops on it going up. The scene is not the robot: a note (as the
    built variants' arm joints get), naming where the joint stopped, the end and the pair."""
    path = _arm(tmp_path, lambda t: t.find(".//body[@name='post']").set("pos", "0.25 0 -0.3"))
    check = _check(validate_file(path, FULL, {}, tier="full"))
    assert check.status == "pass" and "'shoulder' stops at" in check.figure, check
    assert "going upper: the scene: link1/post" in check.figure, check.figure


@pytest.fixture(scope="module")
def pr2_gripper(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """example-robot-data's PR2, pruned to its right gripper (the palm as the root): a parallel gripper whose second
    finger, parallel links and tips follow the first by <mimic>."""
    tree = etree.parse(str(_erd() / "robots" / "pr2_description" / "urdf" / "pr2.urdf"))
    root, keep = tree.getroot(), {"r_gripper_palm_link"}
    joints = list(root.iterfind("joint"))
    for _ in joints:
        keep |= {j.find("child").get("link") for j in joints if j.find("parent").get("link") in keep}
    for element in list(root):
        name = element.find("parent").get("link") if element.tag == "joint" else element.get("name")
        if element.tag not in ("link", "joint") or name not in keep:
            root.remove(element)
    path = tmp_path_factory.mktemp("pr2") / "pr2_gripper.urdf"
    tree.write(str(path))
    return path


def test_a_gripper_closing_on_itself_passes_with_the_closing_pose(pr2_gripper: Path) -> None:
    """The fingertips meet at 0.0085 rad, before the lower end 0: how a gripper closes, not a blocked joint
    (seeded fault: without the closing rule the same stop reads 'its range crosses its own robot')."""
    report = validate_file(pr2_gripper, FULL, {"example-robot-data": _erd()}, tier="full")
    check = _check(report)
    assert check.status == "pass", check
    assert "'r_gripper_l_finger_joint' closes at 0.008" in check.figure, check.figure
    assert "fingers touch (r_gripper_l_finger_tip_link/r_gripper_r_finger_tip_link)" in check.figure
    assert "crosses its own robot" not in check.figure


GRIPPER = """<mujoco model="gripper">
  <worldbody>
    <body name="palm" pos="0 0 0.3">
      <geom type="box" size="0.06 0.02 0.01" mass="0.3"/>
      <body name="left" pos="-0.045 0 -0.045">
        <joint name="left_slide" type="slide" axis="1 0 0" range="0 0.08"/>
        <geom type="box" size="0.01 0.01 0.03" mass="0.5"/>
      </body>
      <body name="right" pos="0.045 0 -0.045">
        <joint name="right_slide" type="slide" axis="-1 0 0" range="0 0.08"/>
        <geom type="box" size="0.01 0.01 0.03" mass="0.5"/>
      </body>
    </body>
  </worldbody>
  <actuator>
    <position name="left_servo" joint="left_slide" kp="50" ctrlrange="0 0.08" forcerange="-2 2"/>
    <position name="right_servo" joint="right_slide" kp="50" ctrlrange="0 0.08" forcerange="-2 2"/>
  </actuator>
</mujoco>
"""


def test_a_gripper_on_its_own_closing_its_fingers_apart_passes_with_the_closing_pose(tmp_path: Path) -> None:
    """A two-finger gripper as a file of its own: the palm is its fixed base, each finger has a servo of its own
    (no <mimic>), and each finger alone meets the other 10 mm short of its 80 mm stroke. Seeded fault: the same palm
    on a free joint is a trunk, its chains legs that meet, and the stop reads 'its range crosses its own robot'."""
    path = tmp_path / "gripper.xml"
    path.write_text(GRIPPER)
    check = _check(validate_file(path, FULL, {}, tier="full"))
    assert check.status == "pass", check
    assert "'left_slide' closes at 0.07" in check.figure and "fingers touch (left/right)" in check.figure, check
    path.write_text(GRIPPER.replace('<body name="palm" pos="0 0 0.3">', '<body name="palm" pos="0 0 0.3"><freejoint/>'))
    check = _check(validate_file(path, FULL, {}, tier="full"))
    assert "closes at" not in check.figure and "crosses its own robot" in check.figure, check.figure


def test_joints_quirks_tolerance_ignore_and_effort(tmp_path: Path) -> None:
    """The settings leave a joint out of range_of_motion with its reason, rate a weak joint (gravity_hold passes on
    the settings' effort: seeded fault, forcerange -1 1 fails without it) and start from a keyframe by name."""
    path = _arm(tmp_path, lambda t: t.find(".//position[@name='shoulder']").set("forcerange", "-1 1"))
    weak = validate_file(path, FULL, {}, tier="full")
    assert _check(weak, "gravity_hold").status == "fail"
    quirks = Quirks(
        joints={
            "shoulder": JointSettings(effort=60.0),
            "wrist": JointSettings(ignore={"range_of_motion": "a cable stops it"}),
            "elbow": JointSettings(tolerance=0.5),
        }
    )
    rated = validate_file(path, FULL, {}, tier="full", quirks=quirks)
    assert _check(rated, "gravity_hold").status == "pass"
    motion = _check(rated)
    assert motion.figure.startswith("3 joint(s)") and "'wrist' left out: a cable stops it" in motion.figure
    tree = etree.parse(str(ARM))
    key = etree.SubElement(tree.find(".//keyframe"), "key", name="bent", qpos="0 1 1 0.02", ctrl="0 1 1 0.02")
    assert key is not None
    tree.write(str(tmp_path / "two_keys.xml"))
    bent = validate_file(tmp_path / "two_keys.xml", FULL, {}, tier="full", quirks=Quirks(keyframe="bent"))
    assert "from keyframe 'bent'" in _check(bent, "settle").figure and "keyframe 'bent'" in _check(bent).figure
    with pytest.raises(SvhdescError, match="keyframe 'stand', which the model does not have \\('home', 'bent'\\)"):
        validate_file(tmp_path / "two_keys.xml", FULL, {}, tier="full", quirks=Quirks(keyframe="stand"))
    with pytest.raises(SvhdescError, match="the settings' joints names joint 'knee', which the model does not have"):
        validate_file(path, FULL, {}, tier="full", quirks=Quirks(joints={"knee": JointSettings(tolerance=0.1)}))


SETTINGS = """[tool.svhdesc.model."arm3.xml"]
keyframe = "home"
joints = {{ wrist = {{ {quirk} }} }}
"""


@pytest.mark.parametrize(
    ("quirk", "words"),
    [
        ("effort = -1", "joint 'wrist': 'effort' must be a number > 0, not -1"),
        ('ignore = { settle = "x" }', "a joint may be left out of gravity_hold or range_of_motion, not 'settle'"),
        ("speed = 1", "unknown key 'speed'"),
    ],
)
def test_bad_joint_settings_are_one_error(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, quirk: str, words: str
) -> None:
    _arm(tmp_path)
    (tmp_path / "pyproject.toml").write_text(SETTINGS.format(quirk=quirk))
    monkeypatch.chdir(tmp_path)
    result = run_cli("validate", "arm3.xml", "--tier", "static", in_process=True)
    assert result.returncode == 2 and result.stdout == "", result
    assert result.stderr.startswith(f"error: {tmp_path / 'pyproject.toml'}:") and words in result.stderr
    assert len(result.stderr.strip().splitlines()) == 1


def test_settings_keyframe_and_joints_from_pyproject(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    _arm(tmp_path)
    (tmp_path / "pyproject.toml").write_text(SETTINGS.format(quirk='ignore = { range_of_motion = "a cable" }'))
    monkeypatch.chdir(tmp_path)
    result = run_cli("validate", "arm3.xml", "--format", "json", in_process=True)
    assert result.returncode == 0, result
    assert "'wrist' left out: a cable" in result.stdout
    (tmp_path / "pyproject.toml").write_text(SETTINGS.format(quirk="tolerance = 0.1").replace("home", "sit"))
    refused = run_cli("validate", "arm3.xml", in_process=True)
    assert refused.returncode == 2 and "keyframe 'sit', which the model does not have ('home')" in refused.stderr


def test_a_xacro_including_a_fifo_is_refused_not_waited_on(tmp_path: Path) -> None:
    os.mkfifo(tmp_path / "pipe.xacro")
    (tmp_path / "robot.urdf.xacro").write_text(
        '<robot name="r" xmlns:xacro="http://www.ros.org/wiki/xacro">\n'
        '  <xacro:include filename="pipe.xacro"/>\n  <link name="base"/>\n</robot>\n'
    )
    try:  # a process of its own, bounded: without the guard the include's read waits for a writer forever
        result = run_cli("validate", str(tmp_path / "robot.urdf.xacro"), "--tier", "static", timeout=60)
    except subprocess.TimeoutExpired:
        pytest.fail("validate waited on the FIFO")
    assert result.returncode == 2 and result.stdout == "", result
    assert result.stderr.strip() == (
        f"error: {tmp_path / 'robot.urdf.xacro'}:2: includes {tmp_path / 'pipe.xacro'}, which is not a regular file "
        "(a FIFO, a device, a folder)"
    )


FLOATING = """<mujoco model="hopper">
  <compiler angle="radian"/>
  <worldbody>
    <geom name="floor" type="plane" size="2 2 0.1"/>
    <body name="torso" pos="0 0 0.3">
      <freejoint/>
      <geom name="torso" type="box" size="0.1 0.1 0.05" mass="2"/>
      <body name="leg" pos="0 0 -0.05">
        <joint name="hip" axis="0 1 0" range="-0.5 0.5"/>
        <geom name="leg" type="capsule" fromto="0 0 0 0 0 -0.2" size="0.02" mass="0.3"/>
      </body>
    </body>
  </worldbody>
  <actuator>
    <position name="hip" joint="hip" kp="50" kv="2" ctrlrange="-0.5 0.5" forcerange="-20 20"/>
  </actuator>
  <keyframe>
    <key name="stand" qpos="0 0 0.3 1 0 0 0 0" ctrl="0"/>
  </keyframe>
</mujoco>
"""


def test_a_floating_robot_falling_through_its_floor_fails_settle(tmp_path: Path) -> None:
    """The hopper lands on its floor from its keyframe and settles; seeded fault: its geoms collide with nothing
    (contype 0, as a visual-only class writes them), so it falls through the floor, at the floating body's line.
    range_of_motion holds the floating base where it rests while the hip moves."""
    clean = tmp_path / "hopper.xml"
    clean.write_text(FLOATING)
    report = validate_file(clean, FULL, {}, tier="full")
    assert _check(report, "settle").status == "pass" and _check(report).status == "pass", report.checks
    faulty = tmp_path / "ghost.xml"
    faulty.write_text(
        FLOATING.replace('mass="2"/>', 'mass="2" contype="0" conaffinity="0"/>').replace(
            'mass="0.3"/>', 'mass="0.3" contype="0" conaffinity="0"/>'
        )
    )
    (finding,) = _check(validate_file(faulty, FULL, {}, tier="full"), "settle").findings
    assert finding.message.startswith("body 'torso' falls through the floor 'floor'"), finding
    assert finding.line == 5 and "contype, conaffinity" in finding.message


WHEEL = """<mujoco model="cart">
  <compiler angle="radian"/>
  <option integrator="implicitfast"/>
  <worldbody>
    <body name="base" pos="0 0 0.5">
      <geom type="box" size="0.1 0.05 0.02" mass="1"/>
      <body name="wheel" pos="0 0.07 0">
        <joint name="wheel" axis="0 1 0" damping="0.01"/>
        <geom type="cylinder" size="0.05 0.01" euler="1.5708 0 0" mass="0.2"/>
      </body>
    </body>
  </worldbody>
  <actuator>
    <velocity name="wheel" joint="wheel" kv="1" ctrlrange="-10 10"/>
  </actuator>
</mujoco>
"""


def test_a_velocity_servo_too_weak_for_its_joint_fails_velocity_tracking(tmp_path: Path) -> None:
    """The wheel turns at 5 rad/s when told (kv 1 against damping 0.01: 1 % slow); seeded fault: damping 1, as
    much as the servo's gain, halves the speed, at the actuator's line. (A URDF's joints: test_full_tier.py.)"""
    clean = tmp_path / "cart.xml"
    clean.write_text(WHEEL)
    check = _check(validate_file(clean, FULL | {"velocity_tracking"}, {}, tier="full"), "velocity_tracking")
    assert check.status == "pass" and check.figure.startswith("1 velocity servo(s)"), check
    faulty = tmp_path / "stiff.xml"
    faulty.write_text(WHEEL.replace('damping="0.01"', 'damping="1"'))
    findings = _check(
        validate_file(faulty, FULL | {"velocity_tracking"}, {}, tier="full"), "velocity_tracking"
    ).findings
    assert [f.line for f in findings] == [14, 14], findings
    assert "joint 'wheel' turns at 2.5" in findings[0].message and "off by 50" in findings[0].message


def test_svhdesc_yaml_carries_keyframe_and_joints(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """An svhdesc.yaml's validate: section takes the same keys (its faults at the YAML's line); a URDF names no
    keyframe (its rest pose is pose = {...}), and one given is an error."""
    _arm(tmp_path)
    monkeypatch.chdir(tmp_path)
    (tmp_path / "svhdesc.yaml").write_text("validate:\n  keyframe: home\n  joints:\n    wrist: {effort: 0}\n")
    refused = run_cli("validate", "arm3.xml", "--tier", "static", in_process=True)
    assert refused.returncode == 2 and refused.stderr.startswith("error: svhdesc.yaml:4: joint 'wrist'"), refused
    (tmp_path / "svhdesc.yaml").write_text("validate:\n  keyframe: home\n  joints:\n    wrist: {tolerance: 0.2}\n")
    assert run_cli("validate", "arm3.xml", in_process=True).returncode == 0
    urdf = tmp_path / "one.urdf"
    urdf.write_text('<robot name="one"><link name="base"/></robot>\n')
    with pytest.raises(SvhdescError, match="a URDF has no keyframes"):
        validate_file(urdf, FULL, {}, tier="full", quirks=Quirks(keyframe="home"))


def test_a_model_diverging_under_its_servos_is_one_finding(tmp_path: Path) -> None:
    """Seeded fault: a timestep of 0.1 s, at which the arm's servos make it diverge: one finding at the first joint
    that diverges alone (not a stroke per joint and end, each diverging again)."""
    path = _arm(tmp_path, lambda t: t.find(".//option").set("timestep", "0.1"))
    (finding,) = _check(validate_file(path, FULL, {}, tier="full")).findings
    assert finding.message.startswith("the model diverges while joint 'shoulder' is driven to its upper end"), finding
    assert finding.line == etree.parse(str(path)).find(".//joint[@name='shoulder']").sourceline
