"""`svhdesc validate PATH` (the full tier, the default): the file compiled by MuJoCo as it stands and simulated.

Clean robots: pybullet_data's Panda (a URDF, read where pip put it) and an arm written here as an MJCF (a keyframe,
position servos, a coupled fingertip, a floor). Each simulated check has a seeded fault that fails it, at the line
of the element it names (velocity_tracking's on pybullet_data's KUKA iiwa: a joint damped past its effort); and a
file with a fault MuJoCo refuses to load unaided is still simulated, the fault a finding.
"""

from __future__ import annotations

import re
from collections.abc import Callable
from pathlib import Path

import pytest
from lxml import etree

from svhdesc.validate.files import known_checks, validate_file
from svhdesc.validate.quirks import Quirks
from tests.support import run_cli
from tests.validate.test_static_files import PACKAGES, _failures, _panda, _set, _write

ALL = set(known_checks())
FULL = {"mujoco_compile", "model_test", "settle", "rest_contacts", "equality_tracking", "gravity_hold"}

ARM = """<mujoco model="arm">
  <compiler angle="radian"/>
  <option timestep="0.002"/>
  <worldbody>
    <geom name="floor" type="plane" size="2 2 0.1"/>
    <body name="base" pos="0 0 0.1">
      <geom type="cylinder" size="0.05 0.05"/>
      <body name="upper" pos="0 0 0.1">
        <joint name="shoulder" axis="0 1 0" range="-1.5 1.5"/>
        <geom type="capsule" fromto="0.04 0 0 0.3 0 0" size="0.03" mass="1"/>
        <body name="fore" pos="0.3 0 0">
          <joint name="elbow" axis="0 1 0" range="-1.5 1.5"/>
          <geom type="capsule" fromto="0.04 0 0 0.25 0 0" size="0.025" mass="0.5"/>
          <body name="finger" pos="0.25 0 0">
            <joint name="finger" axis="0 1 0" range="-1 1"/>
            <geom type="box" size="0.03 0.01 0.01" pos="0.03 0 0" mass="0.05"/>
            <body name="tip" pos="0.06 0 0">
              <joint name="tip" axis="0 1 0" range="-1 1"/>
              <geom type="box" size="0.02 0.01 0.01" pos="0.02 0 0" mass="0.02"/>
            </body>
          </body>
        </body>
      </body>
    </body>
  </worldbody>
  <equality>
    <joint name="tip_follows_finger" joint1="tip" joint2="finger" polycoef="0 1 0 0 0" solref="0.004 1"/>
  </equality>
  <actuator>
    <position name="shoulder" joint="shoulder" kp="200" kv="20" ctrlrange="-1.5 1.5" forcerange="-30 30"/>
    <position name="elbow" joint="elbow" kp="100" kv="10" ctrlrange="-1.5 1.5" forcerange="-15 15"/>
    <position name="finger" joint="finger" kp="5" kv="0.2" ctrlrange="-1 1" forcerange="-2 2"/>
  </actuator>
  <keyframe>
    <key name="home" qpos="0 0 0 0" ctrl="0 0 0"/>
  </keyframe>
</mujoco>
"""


def _arm(tmp_path: Path, old: str = "", new: str = "") -> Path:
    assert old in ARM
    path = tmp_path / "arm.xml"
    path.write_text(ARM.replace(old, new, 1))
    return path


def _line(path: Path, text: str) -> int:
    return next(n for n, line in enumerate(path.read_text().splitlines(), start=1) if text in line)


def test_the_clean_arm_and_panda_pass_every_check(tmp_path: Path) -> None:
    arm = validate_file(_arm(tmp_path), ALL, {}, tier="full")
    assert _failures(arm) == {}
    assert {c.name for c in arm.checks if c.status == "pass"} >= FULL - {"mujoco_compile"}
    panda = validate_file(_write(_panda(), tmp_path / "panda.urdf"), ALL, PACKAGES, tier="full")
    assert _failures(panda) == {}
    statuses = {c.name: c.status for c in panda.checks}
    assert statuses["rest_contacts"] == "skipped"  # a URDF states no pose
    # 7 of its 8 driven joints ramp at half their <limit velocity> on their effort (joint5: too short to settle)
    velocity = next(c for c in panda.checks if c.name == "velocity_tracking")
    assert velocity.status == "pass" and velocity.figure.startswith("7 joint(s) ramped at 0.5 x"), velocity
    assert {n for n, s in statuses.items() if s == "pass"} >= FULL - {"rest_contacts"}


# check -> (old text, new text, the text of the line the finding points at, the fault's words)
MJCF_SEEDS: dict[str, tuple[str, str, str | None, str]] = {
    "gravity_hold": (
        'forcerange="-30 30"',
        'forcerange="-1 1"',
        '<position name="shoulder"',  # where the rating is written
        "to hold against gravity in its 1 keyframe",
    ),
    "equality_tracking": (  # a coupling as soft as a 0.5 s spring: the tip hangs instead of following
        'solref="0.004 1"',
        'solref="0.5 1"',
        '<joint name="tip_follows_finger"',
        "off by up to",
    ),
    "settle": ('timestep="0.002"', 'timestep="0.08"', "<option", "timestep 0.08"),  # at the timestep it ran at
    "rest_contacts": ('qpos="0 0 0 0"', 'qpos="1.5 0 0 0"', '<body name="upper"', "'upper' and 'world'"),
}


@pytest.mark.parametrize("kind", sorted(MJCF_SEEDS))
def test_each_simulated_check_fails_on_its_seeded_fault(tmp_path: Path, kind: str) -> None:
    old, new, at, words = MJCF_SEEDS[kind]
    path = _arm(tmp_path, old, new)
    failures = _failures(validate_file(path, ALL, {}, tier="full"))
    assert kind in failures, failures
    finding = next(f for f in failures[kind] if words in f.message)
    assert finding.file == str(path) and finding.line == (_line(path, at) if at else None), finding


def test_gravity_hold_names_the_effort_that_would_pass(tmp_path: Path) -> None:
    tree = _panda()
    _set("joint[@name='panda_joint2']/limit", effort="2")(tree.getroot())
    path = _write(tree, tmp_path / "panda.urdf")
    (finding,) = _failures(validate_file(path, ALL, PACKAGES, tier="full"))["gravity_hold"]
    assert "joint 'panda_joint2' is rated 2 N m" in finding.message
    assert finding.line == etree.parse(str(path)).find("joint[@name='panda_joint2']/limit").sourceline
    needed = float(finding.remedy.split('"')[1])
    passing = _panda()
    _set("joint[@name='panda_joint2']/limit", effort=str(needed))(passing.getroot())
    again = validate_file(_write(passing, tmp_path / "fixed.urdf"), {"gravity_hold"}, PACKAGES, tier="full")
    assert _failures(again) == {}


def _massless(root: etree._Element) -> None:
    _set("link[@name='panda_link3']/inertial/mass", value="0")(root)
    _set("link[@name='panda_link3']/inertial/inertia", ixx="0", iyy="0", izz="0", ixy="0", ixz="0", iyz="0")(root)


def _second_axis(root: etree._Element) -> None:
    etree.SubElement(root.find("joint[@name='panda_joint3']"), "axis", xyz="1 0 0")


# A fault MuJoCo refuses unaided: either still simulated (the fault reported by its static check) or, where MuJoCo
# cannot open the file at all, a mujoco_compile finding at the source's line.
REFUSED: dict[str, tuple[Callable[[etree._Element], None], str, str | None]] = {
    "massless_link": (_massless, "inertials", None),
    # MuJoCo names the element it read first of the two: the joint's own axis, two lines below the joint's tag
    "repeated_axis": (_second_axis, "mujoco_compile", '<joint name="panda_joint3"'),
}


@pytest.mark.parametrize("kind", sorted(REFUSED))
def test_a_fault_is_a_finding_not_a_refusal(tmp_path: Path, kind: str) -> None:
    seed, check, at = REFUSED[kind]
    tree = _panda()
    seed(tree.getroot())
    path = _write(tree, tmp_path / "panda.urdf")
    report = validate_file(path, ALL, PACKAGES, tier="full")
    statuses = {c.name: c.status for c in report.checks}
    assert check in _failures(report)
    if at is None:  # simulated anyway, saying how
        compiled = next(c for c in report.checks if c.name == "mujoco_compile")
        assert compiled.status == "pass" and "masses below 1e-6 kg" in compiled.figure
        assert statuses["settle"] == "pass" and statuses["gravity_hold"] in {"pass", "fail"}
    else:
        (finding,) = _failures(report)["mujoco_compile"]
        first_axis = next(e for e in etree.parse(str(path)).iterfind("joint[@name='panda_joint3']/axis"))
        assert finding.line == first_axis.sourceline > _line(path, at) and "repeated element" in finding.message
        assert statuses["settle"] == "skipped"


def test_the_cli_runs_the_full_tier_by_default(tmp_path: Path) -> None:
    path = _arm(tmp_path, 'forcerange="-30 30"', 'forcerange="-1 1"')
    result = run_cli("validate", str(path), "--format", "junit", in_process=True)
    assert result.returncode == 1, result.stdout + result.stderr
    cases = {c.get("name"): c for c in etree.fromstring(result.stdout.encode()).iter("testcase")}
    assert cases["gravity_hold"].find("failure") is not None and cases["settle"].find("failure") is None
    assert "load up to" in cases["gravity_hold"].findtext("system-out")
    static = run_cli("validate", str(path), "--tier", "static", in_process=True)
    assert static.returncode == 0, static.stdout


def test_jobs_spread_the_models_and_change_nothing(tmp_path: Path) -> None:
    _arm(tmp_path, 'forcerange="-30 30"', 'forcerange="-1 1"')
    _write(_panda(), tmp_path / "panda.urdf")
    (tmp_path / "meshes").symlink_to(PACKAGES["meshes"])
    one = run_cli("validate", str(tmp_path), in_process=True)
    two = run_cli("validate", str(tmp_path), "-j", "2", in_process=True)
    assert one.returncode == two.returncode == 1 and one.stdout == two.stdout, (one.stdout, two.stdout, two.stderr)
    assert "gravity_hold" in one.stdout and "2 model(s)" in one.stdout
    refused = run_cli("validate", str(tmp_path), "-j", "0", in_process=True)
    assert refused.returncode == 2 and refused.stderr.startswith("error:") and "--jobs" in refused.stderr


PANDA_HOME = {"panda_joint2": -0.785, "panda_joint4": -2.356, "panda_joint6": 1.571, "panda_joint7": 0.785}


def test_a_urdf_rest_pose_from_the_settings_is_where_contacts_are_judged(tmp_path: Path) -> None:
    """A URDF states no pose; [tool.svhdesc] pose = {...} gives one (a keyframe 'rest' of the compiled model), where
    settle starts and rest_contacts judges: the Panda's home is clear, its zero pose folds the hand onto the
    forearm (seeded fault: the pose not passed to compile_urdf: rest_contacts is skipped in both)."""
    path = _write(_panda(), tmp_path / "panda.urdf")
    home = validate_file(path, ALL, PACKAGES, tier="full", quirks=Quirks(PANDA_HOME))
    statuses = {c.name: c.status for c in home.checks}
    assert statuses["rest_contacts"] == "pass" and statuses["settle"] == "pass", home.checks
    folded = validate_file(
        path, ALL, PACKAGES, tier="full", quirks=Quirks({"panda_joint4": -0.07, "panda_joint6": 0.0})
    )
    (finding, *_) = _failures(folded)["rest_contacts"]
    assert "'panda_hand' and 'panda_link5'" in finding.message and "keyframe 'rest'" in finding.message
    assert finding.line == etree.parse(str(path)).find("link[@name='panda_link5']").sourceline
    package = f"meshes={PACKAGES['meshes']}"
    unposed = run_cli("validate", str(path), "--package", package, in_process=True)  # no pose: skipped, says why
    assert unposed.returncode == 0 and "rest_contacts" not in unposed.stdout, unposed.stdout


def _kuka(tmp_path: Path, name: str, **limit: str) -> Path:
    """pybullet_data's KUKA iiwa (its meshes where pip put them), its second joint damped 1000 times as much as the
    file says (0.5 -> 500 N m s: 2500 N m at half its 10 rad/s, against an effort of 300), its <limit> edited."""
    import pybullet_data

    source = Path(pybullet_data.getDataPath()) / "kuka_iiwa" / "model.urdf"
    tree = etree.parse(str(source))
    for mesh in tree.iterfind(".//mesh"):
        mesh.set("filename", str(source.parent / mesh.get("filename")))
    _set("joint[@name='lbr_iiwa_joint_2']/dynamics", damping="500")(tree.getroot())
    _set("joint[@name='lbr_iiwa_joint_2']/limit", **limit)(tree.getroot())
    return _write(tree, tmp_path / name)


def test_velocity_tracking_fails_a_joint_its_damping_holds_back_at_its_limit(tmp_path: Path) -> None:
    """A URDF's joints ramp alone from the rest pose at half their <limit velocity>, on their rated effort. Seeded
    fault: the KUKA's second joint damped 1000 times over crawls at 0.61 rad/s of the 5 asked: a finding at its
    <limit> line naming the effort the speed needs and what would pass, in the text and JSON reports as the other
    checks' findings; the other joints pass or are left out with the reason (a ramp too short for their servo).
    The velocity limit it names passes (the joint ramped, not left out), and so does the effort."""
    import json

    from svhdesc.validate.findings import render

    path = _kuka(tmp_path, "kuka.urdf")
    report = validate_file(path, {"velocity_tracking"}, {}, tier="full")
    check = next(c for c in report.checks if c.name == "velocity_tracking")
    assert check.status == "fail" and check.figure.startswith("5 joint(s) ramped at 0.5 x their velocity limit")
    assert "'lbr_iiwa_joint_7' left out: its ramp at 5 rad/s lasts 0.611 s, under 16 x" in check.figure
    (finding,) = check.findings
    assert finding.line == etree.parse(str(path)).find("joint[@name='lbr_iiwa_joint_2']/limit").sourceline
    assert finding.message.startswith("joint 'lbr_iiwa_joint_2' moves at 0.6"), finding
    assert "on a ramp at 5 (0.5 x its velocity limit 10)" in finding.message and "87." in finding.message
    assert "that speed needs 24" in finding.message and "rated 300" in finding.message
    effort, velocity = (float(v) for v in re.fullmatch(r'effort="(.+)" or velocity="(.+)"', finding.remedy).groups())
    assert 2400 < effort < 3000 and 1.0 < velocity < 1.3, finding.remedy
    shown = render([report], "text")
    assert f"kuka.urdf:{finding.line}: velocity_tracking: joint 'lbr_iiwa_joint_2'" in shown
    assert f"(would pass: {finding.remedy})" in shown
    (listed,) = next(c for c in json.loads(render([report], "json"))[0]["checks"] if c["name"] == "velocity_tracking")[
        "findings"
    ]
    assert listed["line"] == finding.line and listed["remedy"] == finding.remedy
    slower = _kuka(tmp_path, "slower.urdf", velocity=f"{velocity:g}")
    passing = next(
        c for c in validate_file(slower, {"velocity_tracking"}, {}, tier="full").checks if c.name == "velocity_tracking"
    )
    assert passing.status == "pass" and passing.figure.startswith("5 joint(s) ramped"), passing
    stronger = _kuka(tmp_path, "stronger.urdf", effort=f"{effort:g}")
    assert _failures(validate_file(stronger, {"velocity_tracking"}, {}, tier="full")) == {}
