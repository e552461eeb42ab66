"""validate's checks on a robot that is not the SVH: the hand-written three-joint arm with a sliding finger of
tests/data/arm3 (no build, no configuration), each check failing on a seeded fault and naming the culprit.

Seeded faults (each an lxml edit of a copy): a post moved into the arm's way (range_of_motion names the pair); a
coupling that makes two bodies moved by one joint meet (the pair is named although both move); a weak elbow servo
(gravity_hold fails, range_of_motion says gravity needs all of its rated force); an elbow servo too soft for its
friction (range_of_motion fails); a slow shoulder (range_of_motion gives it its time), and one slowed by a flap until
its time runs out (range_of_motion names the pair it touched on the way); a soft wrist limit
(range_of_motion: through its limit); a keyframe folding the arm into itself (self_collision fails); MuJoCo Warp and
MJX not importable (batch skipped with the reason, exit 0); MJX's put_model refusing a cylinder-mesh pair (that half
skipped); gravity 1e12 (load_limits names the joint that ran away); validate.tip_load ignored (the derived 50 N
instead of the config's 7 N).
"""

from __future__ import annotations

import shutil
import sys
from collections.abc import Callable
from pathlib import Path

import mujoco
import pytest
from lxml import etree

from svhdesc.validate.batch import _engine, check_batch, mjx_accepts
from svhdesc.validate.collision import check_self_collision
from svhdesc.validate.hold import BOUND, check_gravity_hold
from svhdesc.validate.load_limits import LOAD_FACTOR, LOAD_MAX, check_load_limits, tip_loads
from svhdesc.validate.options import Options
from svhdesc.validate.pair import ModelPair, load_pair
from svhdesc.validate.range_of_motion import check_range_of_motion, drive_speed
from svhdesc.validate.simulate import check_simulation
from tests.support import REPO, run_cli

ARM = REPO / "tests" / "data" / "arm3" / "arm3.xml"
SVH = REPO / "generated" / "svh_right"
OPTIONS = Options()

Edit = Callable[[etree._ElementTree], None]


def arm(tmp_path: Path, edit: Edit | None = None) -> ModelPair:
    tree = etree.parse(str(ARM))
    if edit is not None:
        edit(tree)
    path = tmp_path / "arm3.xml"
    tree.write(str(path))
    return load_pair(tmp_path / "arm3.urdf", path)  # the URDF is not read by these checks


def only(checks: list) -> object:
    (check,) = checks
    return check


def test_unmodified_arm_passes_and_every_actuated_joint_is_driven(tmp_path: Path) -> None:
    pair = arm(tmp_path)
    motion = only(check_range_of_motion(pair, OPTIONS))
    assert motion.status == "pass", motion.detail
    assert list(motion.data["driven"]) == ["shoulder", "elbow", "wrist", "finger_slide"]  # no `arm:` list needed
    assert all(e["fraction"] > 0.99 for e in motion.data["driven"].values())
    assert not motion.data["notes"]
    hold = only(check_gravity_hold(pair, OPTIONS))
    assert hold.status == "pass" and hold.data["keyframes"]["home"]["drift"] < BOUND, hold.detail
    assert only(check_self_collision(pair, OPTIONS)).status == "pass"


def test_arm_joint_blocked_by_a_collision_names_the_pair(tmp_path: Path) -> None:
    """The post moved under the arm: the shoulder stops on it, and the note names link1/post (an arm's range may
    cross its surroundings; a stop with nothing in contact is the failure, see the weak servo below)."""
    pair = arm(tmp_path, lambda t: t.find(".//body[@name='post']").set("pos", "0.25 0 -0.3"))
    check = only(check_range_of_motion(pair, OPTIONS))
    shoulder = check.data["driven"]["shoulder"]
    assert shoulder["fraction"] < 0.9 and shoulder["blocked_by"]["upper"][0] == "link1/post"
    assert "shoulder stops at" in check.detail and "link1/post" in check.detail


def couple_wrist_to_shoulder(tree: etree._ElementTree) -> None:
    """The wrist follows the shoulder x1.8 (its servo removed), the elbow folded at home: the shoulder's stroke
    swings link3 into link1, two bodies that both move with it."""
    servo = tree.find(".//position[@name='wrist']")
    servo.getparent().remove(servo)
    equality = etree.SubElement(etree.SubElement(tree.getroot(), "equality"), "joint")
    equality.attrib.update({"joint1": "wrist", "joint2": "shoulder", "polycoef": "0 1.8 0 0 0"})
    tree.find(".//key[@name='home']").attrib.update({"qpos": "0 2.2 0 0.02", "ctrl": "0 2.2 0.02"})


def test_blocking_pair_is_named_when_both_bodies_move_with_the_joint(tmp_path: Path) -> None:
    check = only(check_range_of_motion(arm(tmp_path, couple_wrist_to_shoulder), OPTIONS))
    shoulder = check.data["driven"]["shoulder"]
    assert shoulder["fraction"] < 0.95
    assert shoulder["blocked_by"]["upper"][0] == "link1/link3", shoulder


def weak_elbow(tree: etree._ElementTree) -> None:
    tree.find(".//joint[@name='elbow']").set("actuatorfrcrange", "-0.5 0.5")
    tree.find(".//position[@name='elbow']").set("forcerange", "-0.5 0.5")


def test_weak_arm_servo_fails_gravity_hold_and_range_of_motion_says_why(tmp_path: Path) -> None:
    """A 0.5 N m elbow cannot hold its forearm: gravity_hold fails at home; range_of_motion says the elbow stops where
    gravity needs all of its rated force (what a source rated so allows: Talos lifts its arm sideways only so far),
    a note that does not fail the check."""
    pair = arm(tmp_path, weak_elbow)
    hold = only(check_gravity_hold(pair, OPTIONS))
    assert hold.status == "fail" and "home: elbow leaves it by" in hold.detail, hold.detail
    motion = only(check_range_of_motion(pair, OPTIONS))
    assert motion.status == "pass" and "elbow stops at" in motion.detail, motion.detail
    assert "need all of its drive's 0.5 N m, its rating stops it there" in motion.detail
    assert set(motion.data["driven"]["elbow"]["effort_bound"]) == {"start", "upper"}


def sticky_elbow(tree: etree._ElementTree) -> None:
    """Friction 8 N m against a servo of kp 10 N m/rad: it stalls 0.8 rad short, its force far below its 60 N m."""
    tree.find(".//joint[@name='elbow']").set("frictionloss", "8")
    tree.find(".//position[@name='elbow']").set("kp", "10")


def test_servo_too_soft_for_its_friction_fails_range_of_motion(tmp_path: Path) -> None:
    """Seeded fault: sticky_elbow. Stopped short with nothing in contact and its drive below its force limit: the
    model's fault (a kp that cannot beat the joint's friction), not the rating's."""
    motion = only(check_range_of_motion(arm(tmp_path, sticky_elbow), OPTIONS))
    assert motion.status == "fail", motion.detail
    assert "elbow stops at" in motion.detail and "its drive below its force limit" in motion.detail
    assert "effort_bound" not in motion.data["driven"]["elbow"]


def slow_shoulder(tree: etree._ElementTree) -> None:
    """Damping 100 N m s/rad: at its 60 N m the shoulder turns at most 0.6 rad/s (a motor rated so, as `svhdesc
    init` damps the Kinova's 0.63 rad/s joints): 3 rad take over 5 s."""
    tree.find(".//joint[@name='shoulder']").set("damping", "100")


def slow_shoulder_under_a_flap(tree: etree._ElementTree) -> None:
    """The slow shoulder lifts the arm into a flap hinged above it, damped 65 N m s/rad: the arm pushes it aside for
    about 7 s, then swings free, 0.5 rad short when its stroke's 8 s run out, nothing in contact at the end (TIAGo's
    arm_left_3_link scraping 3 s along its torso)."""
    slow_shoulder(tree)
    flap = etree.SubElement(tree.find("worldbody"), "body", name="flap", pos="0.3 0.12 0.12", gravcomp="1")
    etree.SubElement(flap, "joint", name="flap", axis="1 0 0", range="-3.1 3.1", damping="65")
    etree.SubElement(flap, "geom", name="flap", type="box", size="0.1 0.12 0.005", pos="0 -0.12 0", mass="0.2")


def test_a_joint_slowed_by_a_contact_on_the_way_names_the_pair(tmp_path: Path) -> None:
    """Seeded fault: _blocking without the pairs touched on the way: 'shoulder stops at -0.984 of -1.5 going start,
    nothing in contact and its drive below its force limit: its servo is too soft' fails the check."""
    motion = only(check_range_of_motion(arm(tmp_path, slow_shoulder_under_a_flap), OPTIONS))
    shoulder = motion.data["driven"]["shoulder"]
    assert 0.5 < shoulder["fraction"] < 0.95, shoulder
    assert shoulder["blocked_by"]["start"][0] in ("link1/flap (on the way)", "link2/flap (on the way)"), shoulder
    assert motion.status == "pass" and "its range crosses its own robot" in motion.detail, motion.detail


def test_slow_drive_is_given_the_time_its_rating_needs(tmp_path: Path) -> None:
    """Seeded fault: the stroke's time from MIN_SPEED alone (drive_speed returning MIN_SPEED) stopped the shoulder
    short, 'too slow', and failed here."""
    pair = arm(tmp_path, slow_shoulder)
    assert drive_speed(pair.model, pair.model.actuator("shoulder").id) == pytest.approx(0.3)
    motion = only(check_range_of_motion(pair, OPTIONS))
    assert motion.status == "pass", motion.detail
    assert motion.data["driven"]["shoulder"]["fraction"] > 0.99


def soft_wrist_limit(tree: etree._ElementTree) -> None:
    """A soft limit (solref 0.5 s), no damping and a stiff servo: the wrist swings through its stop."""
    tree.find(".//joint[@name='wrist']").attrib.update({"solreflimit": "0.5 1", "damping": "0"})
    tree.find(".//position[@name='wrist']").set("kp", "20000")


def test_joint_through_its_limit_is_named_as_such(tmp_path: Path) -> None:
    check = only(check_range_of_motion(arm(tmp_path, soft_wrist_limit), OPTIONS))
    assert check.status == "fail" and "wrist goes through its limit to -3." in check.detail, check.detail
    assert "wrist stops at" not in check.detail  # not mistaken for a weak servo


def folded_keyframe(tree: etree._ElementTree) -> None:
    key = etree.SubElement(tree.find(".//keyframe"), "key")
    key.attrib.update({"name": "folded", "qpos": "0 2.8 1.2 0.02", "ctrl": "0 2.8 1.2 0.02"})


def test_penetrating_keyframe_fails_self_collision(tmp_path: Path) -> None:
    check = only(check_self_collision(arm(tmp_path, folded_keyframe), OPTIONS))
    assert check.status == "fail" and check.detail.startswith("folded: link1/link3"), check.detail
    assert [p["bodies"] for p in check.data["contacts"]["folded"]] == [["link1", "link3"]]


def test_fingertip_load_is_twice_the_drive_force_at_the_tip(tmp_path: Path) -> None:
    """The slide finger's 20 N servo: a 40 N push, not the SVH's 50 N. Through the wrist hinge (60 N m at about
    0.26 m) the tip would take far more: the weakest drive of the chain sets it. Without hand joints: LOAD_MAX."""
    model = arm(tmp_path).model
    tip = model.body("finger").id
    assert tip_loads(model, [tip], {"finger_slide", "wrist"}) == [pytest.approx(LOAD_FACTOR * 20.0)]
    assert tip_loads(model, [tip], {"wrist"}) == [pytest.approx(LOAD_MAX)]  # 2 x 230 N capped
    assert tip_loads(model, [tip], set()) == [pytest.approx(LOAD_MAX)]


def configured_arm(tmp_path: Path, validate: str) -> ModelPair:
    """arm3 with a configuration: its finger a fingertip, and ``validate`` as the config's validate section."""
    shutil.copy(ARM, tmp_path / "arm3.xml")
    config = tmp_path / "arm3.yaml"
    config.write_text(f"hand: {{fingertips: [finger]}}\n{validate}\nvariants:\n  arm3: {{xacro: arm3.urdf}}\n")
    return load_pair(tmp_path / "arm3.urdf", tmp_path / "arm3.xml", config_path=config)


def test_tip_load_from_the_config(tmp_path: Path) -> None:
    """validate.tip_load sets the push on every fingertip; without it, the derived load (50 N here: this config names
    no channel, so no hand drive limits the finger). Seeded: load_limits ignoring the setting gave 50 N here."""
    given = only(check_load_limits(configured_arm(tmp_path, "validate: {tip_load: 7}"), OPTIONS))
    assert given.data["loads_n"] == {"finger": 7.0}
    derived = only(check_load_limits(configured_arm(tmp_path, ""), OPTIONS))
    assert derived.data["loads_n"] == {"finger": pytest.approx(LOAD_MAX)}


def test_bad_tip_load_is_one_error_line(tmp_path: Path) -> None:
    shutil.copy(ARM, tmp_path / "arm3.xml")
    (tmp_path / "arm3.yaml").write_text("validate: {tip_load: -5}\nvariants:\n  arm3: {xacro: arm3.urdf}\n")
    args = ("validate", "--config", str(tmp_path / "arm3.yaml"), "--out", str(tmp_path), "--checks", "load_limits")
    result = run_cli(*args, in_process=True)
    lines = result.stderr.strip().splitlines()
    assert result.returncode == 2 and len(lines) == 1, result.stderr
    assert lines[0].startswith("error:") and "validate.tip_load" in lines[0], lines[0]


def test_simulate_names_when_and_where_it_diverged_and_what_helps(tmp_path: Path) -> None:
    """Gravity 1e12 m/s^2: the random-target run diverges; the detail says when, at which joint, and the settings
    that help (seeded fault: the diverged list left empty: 'warnings mjWARN_BADQACC x1' alone, as icub's said)."""
    pair = arm(tmp_path, lambda t: t.find("option").set("gravity", "0 0 -1e12"))
    check = next(c for c in check_simulation(pair, OPTIONS) if c.name == "simulate")
    assert check.status == "fail" and "mjWARN_BADQACC" in check.detail, check.detail
    diverged = check.data["diverged"]
    assert diverged is not None and diverged["joint"] in ("shoulder", "elbow", "wrist", "finger_slide"), diverged
    assert f"diverged at t = {diverged['t']:.3f} s at joint {diverged['joint']}" in check.detail
    assert "simulation.cone: pyramidal" in check.detail and "joints.NAME.effort" in check.detail


@pytest.mark.skipif(not (SVH / "svh_right.xml").is_file(), reason="generated/svh_right is not built")
def test_load_limits_names_the_joint_that_ran_away(tmp_path: Path) -> None:
    """Gravity 1e12 m/s^2: the loaded run diverges at once, and the detail says when, which joint and what MuJoCo
    warned."""
    target = tmp_path / "svh_right"
    shutil.copytree(SVH, target)
    mjcf = target / "svh_right.xml"
    tree = etree.parse(str(mjcf))
    tree.find("option").set("gravity", "0 0 -1e12")
    tree.write(str(mjcf))
    check = only(check_load_limits(load_pair(target / "svh_right.urdf", mjcf), OPTIONS))
    assert check.status == "fail"
    diverged = check.data["diverged"]
    assert diverged.startswith("diverged at t = 0.000 s: right_hand_") and "ran away" in diverged, diverged
    assert "MuJoCo warns BADQACC" in diverged and diverged in check.detail
    assert check.data["loads_n"] and max(check.data["loads_n"].values()) <= LOAD_MAX


@pytest.mark.skipif(not (SVH / "scene_batch.xml").is_file(), reason="generated/svh_right is not built")
def test_batch_without_its_engines_is_skipped_with_the_reason(monkeypatch: pytest.MonkeyPatch) -> None:
    """Neither MuJoCo Warp nor MJX importable (the `validate` extra alone): skipped, each reason given, exit 0."""
    import mujoco

    for module in ("warp", "mujoco_warp", "mujoco.mjx"):
        monkeypatch.setitem(sys.modules, module, None)  # import raises ImportError, as when not installed
    # `from mujoco import mjx` reads the package's attribute first, set by an earlier test's import of it
    monkeypatch.delattr(mujoco, "mjx", raising=False)
    check = only(check_batch(load_pair(SVH / "svh_right.urdf", SVH / "svh_right.xml"), OPTIONS))
    assert check.status == "skipped", check.detail
    assert "warp not installed" in check.detail and "svhdesc[batch]" in check.detail
    assert "mjx not installed" in check.detail and "svhdesc[batch-mjx]" in check.detail
    args = ("validate", "--urdf", str(SVH / "svh_right.urdf"), "--mjcf", str(SVH / "svh_right.xml"))
    result = run_cli(*args, "--checks", "batch", in_process=True)
    assert result.returncode == 0, result.stdout + result.stderr
    assert "skipped (not applicable): batch (warp not installed" in result.stdout


CYLINDER_MESH = """
<mujoco>
  <asset><mesh name="m" vertex="0 0 0 0.1 0 0 0 0.1 0 0 0 0.1"/></asset>
  <worldbody>
    <body name="a"><freejoint/><geom type="cylinder" size="0.05 0.1"/></body>
    <body name="b" pos="0.5 0 0"><freejoint/><geom type="mesh" mesh="m"/></body>
  </worldbody>
</mujoco>
"""


def test_mjx_refusing_a_cylinder_mesh_pair_is_skipped_and_another_refusal_fails() -> None:
    """MJX's own put_model on a model with a cylinder and a mesh (Talos' case): that half skipped with MJX's
    message; an engine raising anything else is a finding."""
    pytest.importorskip("mujoco.mjx")
    model = mujoco.MjModel.from_xml_string(CYLINDER_MESH)
    status, why = _engine("mjx", lambda: mjx_accepts(model))
    assert status == "skipped" and "CYLINDER" in why and "MESH" in why and "not implemented" in why, why

    def broken() -> None:
        raise ValueError("bad model")

    assert _engine("mjx", broken) == ("refused", "ValueError: bad model")


def test_arm_model_compiles() -> None:
    assert mujoco.MjModel.from_xml_path(str(ARM)).nu == 4
