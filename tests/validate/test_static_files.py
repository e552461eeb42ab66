"""`svhdesc validate PATH --tier static`: a URDF or MJCF as it stands, each fault a finding at its file:line.

The clean robot is pybullet_data's Panda, read where pip put it; every seeded fault is written into a copy in
tmp_path, its meshes still resolved from the wheel (--package meshes=...). Each case names the check that must fail
and the line it must point at: with that check's rule removed or broken, its case fails.
"""

from __future__ import annotations

import json
import os
from collections.abc import Callable
from pathlib import Path

import pybullet_data
import pytest
from lxml import etree

from svhdesc.validate import file_parsers
from svhdesc.validate.file_parsers import PARSER_CHECKS
from svhdesc.validate.files import known_checks, robot_files, validate_file
from svhdesc.validate.findings import FileReport
from svhdesc.validate.static_urdf import RULES
from tests.support import run_cli

PANDA = Path(pybullet_data.getDataPath()) / "franka_panda" / "panda.urdf"
INERTIAL = "<inertial><mass value='1'/><inertia ixx='1' iyy='1' izz='1' ixy='0' ixz='0' iyz='0'/></inertial>"
ONE_LINK = f"<robot name='x'><link name='a'>{INERTIAL}</link></robot>"
PACKAGES = {"meshes": PANDA.parent / "meshes"}
ALL = set(known_checks())


def _panda() -> etree._ElementTree:
    tree = etree.parse(str(PANDA))
    # A gripper as users write one: the second finger mimics the first (clean: the same range).
    assert tree.getroot().find("joint[@name='panda_finger_joint2']/mimic").get("joint") == "panda_finger_joint1"
    return tree


def _write(tree: etree._ElementTree, path: Path) -> Path:
    tree.write(str(path), xml_declaration=True, encoding="utf-8")
    return path


def _failures(report: FileReport) -> dict[str, list]:
    return {c.name: c.findings for c in report.checks if c.status == "fail"}


def test_the_clean_panda_passes_every_static_check(tmp_path: Path) -> None:
    report = validate_file(_write(_panda(), tmp_path / "panda.urdf"), ALL, PACKAGES)
    assert _failures(report) == {}
    assert {c.name for c in report.checks} == {
        "xml",
        "structure",
        "numbers",
        "inertials",
        "joint_limits",
        "mimic",
        "meshes",
        "urdfdom",
        "yourdfpy",
        "sdformat",
    }


def _element(root: etree._Element, xpath: str) -> etree._Element:
    found = root.xpath(xpath)
    assert found, xpath
    return found[0]


def _set(xpath: str, **attributes: str) -> Callable[[etree._Element], etree._Element]:
    def seed(root: etree._Element) -> etree._Element:
        element = _element(root, xpath)
        for key, value in attributes.items():
            element.set(key, value)
        return element

    return seed


def _remove_inertial(root: etree._Element) -> etree._Element:
    link = _element(root, "link[@name='panda_leftfinger']")
    link.remove(link.find("inertial"))
    return _element(root, "joint[@name='panda_finger_joint1']")


def _duplicate_link(root: etree._Element) -> etree._Element:
    copy = etree.fromstring(etree.tostring(_element(root, "link[@name='panda_link3']")))
    root.append(copy)
    return copy


def _second_axis(root: etree._Element) -> etree._Element:
    joint = _element(root, "joint[@name='panda_joint3']")
    return etree.SubElement(joint, "axis", xyz="1 0 0")


def _scale_collision(root: etree._Element) -> etree._Element:
    return _set("link[@name='panda_link4']/collision/geometry/mesh", scale="100 100 100")(root)


# check -> (seed, the fault's words in the finding). The seed returns the element the finding must point at.
SEEDS: dict[str, tuple[str, Callable[[etree._Element], etree._Element], str]] = {
    "negative_mass": ("inertials", _set("link[@name='panda_link3']/inertial/mass", value="-1"), "mass -1"),
    "inertia_not_pd": (
        "inertials",
        _set("link[@name='panda_link3']/inertial/inertia", ixx="-0.1"),
        "positive definite",
    ),
    "triangle": (
        "inertials",
        _set("link[@name='panda_link3']/inertial/inertia", ixx="0.001", iyy="0.001", izz="1"),
        "triangle",
    ),
    "moving_link_without_inertial": ("inertials", _remove_inertial, "no <inertial>"),
    "inverted_limits": (
        "joint_limits",
        _set("joint[@name='panda_joint2']/limit", lower="1.8", upper="-1.8"),
        "inverted",
    ),
    "zero_range": ("joint_limits", _set("joint[@name='panda_joint2']/limit", lower="0", upper="0"), "cannot move"),
    "effort_zero": ("joint_limits", _set("joint[@name='panda_joint5']/limit", effort="0"), "effort 0"),
    "velocity_zero": ("joint_limits", _set("joint[@name='panda_joint5']/limit", velocity="0"), "velocity 0"),
    "mimic_missing_leader": ("mimic", _set("joint[@name='panda_finger_joint2']/mimic", joint="nope"), "not defined"),
    "mimic_beyond_limits": (
        "mimic",
        lambda r: (
            _set("joint[@name='panda_finger_joint2']/mimic", multiplier="2")(r),
            _element(r, "joint[@name='panda_finger_joint2']/limit"),
        )[1],
        "beyond its limits",
    ),
    "missing_mesh": (
        "meshes",
        _set("link[@name='panda_link2']/visual/geometry/mesh", filename="package://meshes/visual/nope.obj"),
        "missing",
    ),
    "collision_far_larger": ("meshes", _scale_collision, "x the size of its visual"),
    "nan_origin": ("numbers", _set("joint[@name='panda_joint3']/origin", xyz="0 nan 0"), "not a finite number"),
    "duplicate_link": ("structure", _duplicate_link, "defined twice"),
    "missing_parent": ("structure", _set("joint[@name='panda_joint4']/parent", link="ghost"), "not defined"),
    "repeated_axis": ("structure", _second_axis, "a second <axis>"),
}


@pytest.mark.parametrize("kind", sorted(SEEDS))
def test_each_seeded_fault_is_a_finding_at_its_line(tmp_path: Path, kind: str) -> None:
    check, seed, words = SEEDS[kind]
    tree = _panda()
    tree = etree.ElementTree(etree.fromstring(etree.tostring(tree)))  # fresh source lines after the clean edit
    path = _write(tree, tmp_path / "panda.urdf")
    tree = etree.parse(str(path))
    element = seed(tree.getroot())
    _write(tree, path)
    line = etree.parse(str(path)).getroot().xpath(tree.getpath(element))[0].sourceline
    failures = _failures(validate_file(path, ALL, PACKAGES))
    assert set(failures) - set(PARSER_CHECKS) == {check}, failures  # the parsers may refuse the same fault
    matching = [f for f in failures[check] if words in f.message]
    assert matching, failures[check]
    assert matching[0].line == line and matching[0].file == str(path)


def test_remedies_name_the_value_that_would_pass(tmp_path: Path) -> None:
    tree = _panda()
    _set("joint[@name='panda_joint2']/limit", lower="1.8", upper="-1.8")(tree.getroot())
    _set("joint[@name='panda_finger_joint2']/mimic", multiplier="2")(tree.getroot())
    failures = _failures(validate_file(_write(tree, tmp_path / "p.urdf"), ALL, PACKAGES))
    assert failures["joint_limits"][0].remedy == 'lower="-1.8" upper="1.8"'
    assert failures["mimic"][0].remedy == 'lower="0" upper="0.08"'  # the finger's 0 .. 0.04 doubled


MJCF = """<mujoco model="arm">
  <compiler angle="radian"/>
  <worldbody>
    <body name="link">
      <joint name="hinge" range="-1 1"/>
      <geom size="0.1" mass="1"/>
    </body>
  </worldbody>
  <actuator>
    <position name="servo" joint="hinge" kp="10" ctrlrange="{ctrl}"/>
  </actuator>
  <keyframe>
    <key name="home" qpos="{q}"/>
  </keyframe>
</mujoco>
"""


@pytest.mark.parametrize(
    ("ctrl", "q", "check", "tag"),
    [("-1 1", "0", None, None), ("-2 1", "0", "actuator_ranges", "position"), ("-1 1", "1.5", "keyframes", "key")],
)
def test_an_mjcf_as_it_stands(tmp_path: Path, ctrl: str, q: str, check: str | None, tag: str | None) -> None:
    path = tmp_path / "arm.xml"
    path.write_text(MJCF.format(ctrl=ctrl, q=q))
    failures = _failures(validate_file(path, ALL, {}))
    if check is None:
        assert failures == {}
        return
    assert set(failures) == {check}
    line = next(e.sourceline for e in etree.parse(str(path)).iter(tag))
    assert failures[check][0].line == line


def test_an_mjcf_that_does_not_compile_is_a_finding_at_its_line(tmp_path: Path) -> None:
    path = tmp_path / "arm.xml"
    path.write_text(MJCF.format(ctrl="-1 1", q="0").replace('joint="hinge"', 'joint="ghost"'))
    failures = _failures(validate_file(path, ALL, {}))
    assert set(failures) == {"mjcf_compile"}
    assert failures["mjcf_compile"][0].line == 10 and "ghost" in failures["mjcf_compile"][0].message


def test_a_folder_walk_reports_every_robot_file_and_broken_ones_as_findings(tmp_path: Path) -> None:
    (tmp_path / "sub").mkdir()
    _write(_panda(), tmp_path / "sub" / "panda.urdf")
    (tmp_path / "broken.urdf").write_text("<robot name='x'>\n<link name='a'>\n</robot>\n")
    (tmp_path / "arm.xml").write_text(MJCF.format(ctrl="-1 1", q="0"))
    (tmp_path / "notes.xml").write_text("<notes/>")  # not a robot file: not walked
    (tmp_path / ".git").mkdir()
    (tmp_path / ".git" / "x.urdf").write_text("<robot/>")
    files = robot_files([tmp_path])
    assert sorted(p.name for p, _ in files) == ["arm.xml", "broken.urdf", "panda.urdf"]
    broken = validate_file(tmp_path / "broken.urdf", ALL, {}, walked=True)
    assert _failures(broken)["xml"][0].line == 3


def _cli(*args: str) -> tuple[int, str, str]:
    """`svhdesc validate ARGS`, the static tier unless ARGS name one (tests/validate/test_full_tier.py: the full)."""
    tier = () if "--tier" in args else ("--tier", "static")
    result = run_cli("validate", *args, *tier, in_process=True)
    return result.returncode, result.stdout, result.stderr


@pytest.fixture
def faulty(tmp_path: Path) -> Path:
    tree = _panda()
    _set("joint[@name='panda_joint5']/limit", effort="0")(tree.getroot())
    return _write(tree, tmp_path / "panda.urdf")


def test_formats_text_github_junit_json(faulty: Path, tmp_path: Path) -> None:
    package = f"meshes={PACKAGES['meshes']}"
    line = etree.parse(str(faulty)).getroot().xpath("joint[@name='panda_joint5']/limit")[0].sourceline
    code, out, _ = _cli(str(faulty), "--package", package)
    assert code == 1 and f"panda.urdf:{line}: joint_limits: joint 'panda_joint5': effort 0" in out
    code, out, _ = _cli(str(faulty), "--package", package, "--format", "github")
    assert code == 1
    assert out.startswith("::error file=") and f",line={line},title=svhdesc joint_limits::joint 'panda_joint5'" in out
    junit_file = tmp_path / "report.xml"
    code, out, _ = _cli(str(faulty), "--package", package, "--format", "junit", "--junit", str(junit_file))
    for document in (out.encode(), junit_file.read_bytes()):
        suites = etree.fromstring(document)
        cases = {c.get("name"): c for c in suites.iter("testcase")}
        assert set(cases) == {"xml", *RULES, *PARSER_CHECKS}
        assert cases["joint_limits"].find("failure") is not None and cases["mimic"].find("failure") is None
    code, out, _ = _cli(str(faulty), "--package", package, "--format", "json")
    (report,) = json.loads(out)
    assert [c["name"] for c in report["checks"] if c["status"] == "fail"] == ["joint_limits"]


def test_select_and_ignore(faulty: Path) -> None:
    package = f"meshes={PACKAGES['meshes']}"
    assert _cli(str(faulty), "--package", package, "--ignore", "joint_limits")[0] == 0
    assert _cli(str(faulty), "--package", package, "--select", "inertials,mimic")[0] == 0
    assert _cli(str(faulty), "--package", package, "--select", "joint_limits")[0] == 1


def test_a_baseline_fails_only_on_new_findings(faulty: Path, tmp_path: Path) -> None:
    package = f"meshes={PACKAGES['meshes']}"
    baseline = tmp_path / "baseline.json"
    code, out, _ = _cli(str(faulty), "--package", package, "--write-baseline", str(baseline))
    assert code == 0 and "1 finding(s)" in out
    assert _cli(str(faulty), "--package", package, "--baseline", str(baseline))[0] == 0
    tree = etree.parse(str(faulty))
    _set("joint[@name='panda_joint6']/limit", velocity="0")(tree.getroot())
    _write(tree, faulty)
    code, out, _ = _cli(str(faulty), "--package", package, "--baseline", str(baseline))
    assert code == 1 and "panda_joint6" in out and "panda_joint5" not in out


def test_bad_input_is_one_error_line(tmp_path: Path) -> None:
    fifo = tmp_path / "pipe.urdf"
    os.mkfifo(fifo)
    (tmp_path / "empty").mkdir()
    (tmp_path / "bad.urdf").write_text("<robot name='x'>\n<link>\n")
    (tmp_path / "robot.urdf.xacro").write_text(XACRO)
    (tmp_path / "macros.xacro").write_text(MACROS)
    (tmp_path / "includes.urdf.xacro").write_text(XACRO.replace("macros.xacro", "absent.xacro"))
    (tmp_path / "ok.urdf").write_text(ONE_LINK)
    cases = {
        (str(fifo),): "not a regular file",
        (str(tmp_path / "empty"),): "no robot file",
        (str(tmp_path / "bad.urdf"),): "bad.urdf:3: not well-formed XML",
        (str(tmp_path / "robot.urdf.xacro"),): "robot.urdf.xacro:3: xacro: Undefined substitution argument side",
        (str(tmp_path / "robot.urdf.xacro"), "--arg", "side"): "expected NAME:=VALUE",
        (str(tmp_path / "includes.urdf.xacro"),): "includes.urdf.xacro:4: xacro: included file",
        (str(tmp_path / "ok.urdf"), "--select", "nope"): "unknown check 'nope'",
        (str(tmp_path / "ok.urdf"), "--tier", "fast"): "'fast' is not one of 'static', 'full'",
    }
    before = sorted(tmp_path.rglob("*"))
    for args, words in cases.items():
        code, _, err = _cli(*args)
        lines = err.strip().splitlines()
        assert code == 2 and len(lines) == 1 and lines[0].startswith("error:") and words in lines[0], (args, err)
    assert sorted(tmp_path.rglob("*")) == before
    assert _cli(str(tmp_path / "ok.urdf"))[0] == 0


# A two-link arm as a xacro: an argument, a macro building names from a prefix, an include. The seeded fault (an
# inverted limit) sits in the included macro file; the finding must point at that file's line, not the expansion's.
XACRO = """<?xml version="1.0"?>
<robot name="arm" xmlns:xacro="http://www.ros.org/wiki/xacro">
  <xacro:property name="side" value="$(arg side)"/>
  <xacro:include filename="macros.xacro"/>
  <link name="base"><inertial><mass value="1"/><inertia ixx="0.01" iyy="0.01" izz="0.01" ixy="0" ixz="0" iyz="0"/>
  </inertial></link>
  <xacro:segment prefix="${side}" parent="base" lower="${LOWER}"/>
</robot>
"""
MACROS = """<?xml version="1.0"?>
<robot xmlns:xacro="http://www.ros.org/wiki/xacro">
  <xacro:macro name="segment" params="prefix parent lower">
    <link name="${prefix}_upper">
      <inertial><mass value="1"/><inertia ixx="0.01" iyy="0.01" izz="0.01" ixy="0" ixz="0" iyz="0"/></inertial>
    </link>
    <joint name="${prefix}_shoulder" type="revolute">
      <parent link="${parent}"/>
      <child link="${prefix}_upper"/>
      <limit lower="${lower}" upper="1.0" effort="10" velocity="1"/>
    </joint>
  </xacro:macro>
</robot>
"""


@pytest.mark.parametrize("lower, failing", [("-1.0", None), ("2.0", "joint_limits")])
def test_a_xacro_with_arguments_reports_at_the_macro_files_line(tmp_path: Path, lower: str, failing: str) -> None:
    (tmp_path / "arm.urdf.xacro").write_text(XACRO.replace("${LOWER}", lower))
    (tmp_path / "macros.xacro").write_text(MACROS)
    code, out, err = _cli(str(tmp_path / "arm.urdf.xacro"), "--arg", "side:=left")
    if failing is None:
        assert code == 0 and "all checks passed" in out, out + err
        return
    line = MACROS.splitlines().index('    <joint name="${prefix}_shoulder" type="revolute">') + 1
    assert code == 1
    assert f"macros.xacro:{line}: {failing}: joint 'left_shoulder'" in out, out
    # A folder's walk expands *.urdf.xacro (the robots) but not the macro files they include.
    files = robot_files([tmp_path])
    assert [p.name for p, _ in files] == ["arm.urdf.xacro"]


@pytest.mark.parametrize("prefix", ['<?xml version="0.0" ?>\n', '<!-- made by a tool -->\n<?xml version="1.0"?>\n'])
def test_a_declaration_only_libxml2_refuses_is_a_finding_and_the_rest_is_checked(tmp_path: Path, prefix: str) -> None:
    tree = _panda()
    _set("joint[@name='panda_joint5']/limit", effort="0")(tree.getroot())
    body = etree.tostring(tree.getroot()).decode()
    path = tmp_path / "panda.urdf"
    path.write_text(prefix + body)
    failures = _failures(validate_file(path, ALL, PACKAGES))
    assert set(failures) - set(PARSER_CHECKS) == {"xml", "joint_limits"}, failures
    (declaration,) = failures["xml"]
    assert declaration.line == prefix.count("\n") and '<?xml version="1.0"?>' in declaration.remedy
    assert failures["joint_limits"][0].line == body[: body.index('name="panda_joint5"')].count("\n") + 1 + (
        prefix.count("\n")
    ) + _limit_offset(body)


def _limit_offset(body: str) -> int:
    """Lines from joint5's tag down to its <limit>."""
    start = body.index('name="panda_joint5"')
    return body[start : body.index("<limit", start)].count("\n")


def test_the_command_line_leaves_no_file_open(tmp_path: Path) -> None:
    # Reading a root tag with iterparse(path) and leaving it at its first event left the file to the garbage
    # collector: "warning: unclosed file" on a hook's output.
    (tmp_path / "arm.xml").write_text(MJCF.format(ctrl="-1 1", q="0"))
    code, out, err = _cli(str(tmp_path / "arm.xml"))
    assert code == 0 and "warning" not in err, err
    # yourdfpy logs its second parse of a declaration lxml refuses as errors (Python's last resort prints them
    # without a handler: only a process of its own shows it, pytest's log capture takes them in process)
    cube = Path(pybullet_data.getDataPath()) / "cube_small.urdf"
    done = run_cli("validate", str(cube), "--tier", "static", "--select", "yourdfpy")
    assert done.returncode == 0 and done.stderr == "", done.stderr


def test_the_parsers_refuse_what_their_users_tools_would(tmp_path: Path) -> None:
    """Seeded faults, each refused by the parsers its users' tools are built on, at the element's line: a link
    defined twice (urdfdom: robot_state_publisher would not start; yourdfpy keeps one), a joint naming a missing
    parent (urdfdom, and sdformat, which parses with it), a root link of mass 0 with joints on it (Gazebo's SDFormat
    drops it and everything below)."""
    panda = etree.tostring(_panda()).decode()
    massless = _panda()
    root_link = massless.getroot().find("link")
    root_link.remove(root_link.find("inertial"))
    cases = {
        "twice.urdf": (
            panda.replace('<link name="panda_link8"', '<link name="panda_link7"', 1),
            {"urdfdom": "link[@name='panda_link7']", "yourdfpy": None},
        ),
        "orphan.urdf": (
            panda.replace('<parent link="panda_link3"/>', '<parent link="panda_link33"/>', 1),
            {"urdfdom": "joint[@name='panda_joint4']", "sdformat": "joint[@name='panda_joint4']"},
        ),
        "massless.urdf": (etree.tostring(massless).decode(), {"sdformat": f"link[@name='{root_link.get('name')}']"}),
    }
    for name, (text, expected) in cases.items():
        (tmp_path / name).write_text(text)
        failures = _failures(validate_file(tmp_path / name, ALL, PACKAGES))
        for check, element in expected.items():
            assert check in failures, (name, check, list(failures))
            if element is not None:  # the element seeded: a link's second definition, the joint, the root link
                line = etree.parse(str(tmp_path / name)).getroot().findall(element)[-1].sourceline
                assert failures[check][0].line == line, failures[check]
    assert "SDFormat drops a link without mass" in failures["sdformat"][0].message


def test_a_parser_not_installed_is_a_skip_naming_its_install(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    (tmp_path / "one.urdf").write_text(ONE_LINK)
    monkeypatch.setattr(file_parsers.shutil, "which", lambda *_, **__: None)
    file_parsers._ign.cache_clear()
    try:
        report = validate_file(tmp_path / "one.urdf", ALL, {})
    finally:
        file_parsers._ign.cache_clear()
    skipped = {c.name: c.reason for c in report.checks if c.status == "skipped"}
    assert "apt-get install liburdfdom-tools" in skipped["urdfdom"] and "apt-get install" in skipped["sdformat"]
    assert report.failed == []
