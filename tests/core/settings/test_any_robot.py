"""A config that describes any robot: no hand, no prefix, no couplings; `inertials: recompute`; `python:` paths.

Each case builds tests/data/mini (milliseconds, in-process) with one thing changed, and reads the outputs.
"""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner
from lxml import etree

from svhdesc.cli import main
from svhdesc.core.settings.config import load_config, resolve_path
from svhdesc.errors import SvhdescError
from tests.support import TESTS

MINI = TESTS / "data" / "mini"
# The mini robot as a robot of its own: no hand section, no coupling spec, both joints driven as an arm.
NO_HAND = """\
arm: {enabled: true, joints: [right_hand_A, right_hand_j2], kp: 1.0}
mass:
  links: {right_hand_base: 0.05, right_hand_p: 0.02, right_hand_t: 0.01}
collision: {mode: hull}
simulation: {timestep: 0.001}
keyframes:
  home: {right_hand_A: 0.1}
variants:
  mini:
    xacro: mini.xacro
"""
BAD_INERTIAL = (
    '<inertial><mass value="0.01"/><inertia ixx="1e-6" ixy="0" ixz="0" iyy="1e-6" iyz="0" izz="5e-6"/></inertial>'
)
GOOD_INERTIAL = (
    '<inertial><mass value="0.01"/><inertia ixx="2e-6" ixy="0" ixz="0" iyy="2e-6" iyz="0" izz="1e-6"/></inertial>'
)


def project(tmp_path: Path) -> Path:
    copy = tmp_path / "mini"
    shutil.copytree(MINI, copy)
    return copy


def edit(path: Path, old: str, new: str) -> None:
    text = path.read_text()
    assert old in text, f"{old!r} not in {path.name}"
    path.write_text(text.replace(old, new, 1))


def build(config: Path, out: Path) -> str:
    """Build; the CLI's stderr (its warnings). Fails the test on a non-zero exit."""
    result = CliRunner().invoke(main, ["build", "--config", str(config), "--out", str(out)])
    assert result.exit_code == 0, result.stderr
    return result.stderr


def urdf(out: Path) -> etree._ElementTree:
    return etree.parse(str(out / "mini" / "mini.urdf"))


def inertia_of(tree: etree._ElementTree, link: str) -> tuple[float, np.ndarray]:
    inertial = tree.find(f"link[@name='{link}']/inertial")
    values = {k: float(v) for k, v in inertial.find("inertia").attrib.items()}
    tensor = np.array(
        [
            [values["ixx"], values["ixy"], values["ixz"]],
            [values["ixy"], values["iyy"], values["iyz"]],
            [values["ixz"], values["iyz"], values["izz"]],
        ]
    )
    return float(inertial.find("mass").get("value")), tensor


# --- no hand, no prefix, no couplings ---------------------------------------------------------------------


def test_a_robot_without_hand_or_couplings_builds(tmp_path: Path) -> None:
    """No `hand`, no `coupling`: the dummy `hand: {prefix: ...}` a new user needed is not needed."""
    source = project(tmp_path)
    (source / "mini.yaml").write_text(NO_HAND)
    config = load_config(source / "mini.yaml")
    sections = config.variants["mini"].settings
    assert sections.hand.prefix is None and sections.coupling is None
    build(source / "mini.yaml", tmp_path / "out")
    tree = urdf(tmp_path / "out")
    assert tree.find(".//mimic") is None
    assert sorted(j.text for j in tree.findall("transmission/joint")) and len(tree.findall("transmission")) == 2
    mjcf = etree.parse(str(tmp_path / "out" / "mini" / "mini.xml"))
    assert mjcf.find(".//equality") is None or len(mjcf.find(".//equality")) == 0
    assert len(mjcf.findall(".//actuator/position")) == 2


def test_the_spec_names_the_robots_own_joints(tmp_path: Path) -> None:
    """Without hand.prefix, the coupling spec names the joints as the robot does."""
    source = project(tmp_path)
    edit(source / "mini.yaml", "  prefix: right_hand\n", "")
    edit(source / "mini.yaml", '{links: "{hand}_*", total: 0.1}', '{links: "right_hand_*", total: 0.1}')
    edit(source / "mini.yaml", "fingertips: [t]", "fingertips: [right_hand_t]")
    edit(source / "mini.yaml", "force_sensor: t", "force_sensor: right_hand_t")
    edit(source / "coupling.yaml", "name: A", "name: right_hand_A")
    edit(source / "coupling.yaml", "{joint: j2, follows: A,", "{joint: right_hand_j2, follows: right_hand_A,")
    edit(source / "mini.yaml", "home: {A: 0.1}", "home: {right_hand_A: 0.1}")
    build(source / "mini.yaml", tmp_path / "own")
    reference = project(tmp_path / "ref")
    build(reference / "mini.yaml", tmp_path / "prefixed")
    for name in ("mini.urdf", "mini.xml"):
        assert (tmp_path / "own" / "mini" / name).read_bytes() == (tmp_path / "prefixed" / "mini" / name).read_bytes()


def test_a_prefixed_hand_may_couple_a_joint_by_its_own_name(tmp_path: Path) -> None:
    """With a prefix, a spec name the robot lacks as <prefix>_<name> is looked up as written."""
    source = project(tmp_path)
    edit(source / "coupling.yaml", "{joint: j2, follows: A,", "{joint: right_hand_j2, follows: A,")
    build(source / "mini.yaml", tmp_path / "out")
    mimic = urdf(tmp_path / "out").find("joint[@name='right_hand_j2']/mimic")
    assert mimic.get("joint") == "right_hand_A" and float(mimic.get("multiplier")) == 0.5


# --- inertials: recompute ---------------------------------------------------------------------------------


def with_source_inertials(source: Path, tip: str, knuckle: str) -> None:
    edit(source / "finger.xacro", '<link name="${prefix}_t">', f'<link name="${{prefix}}_t">{tip}')
    edit(source / "finger.xacro", '<link name="${prefix}_p">', f'<link name="${{prefix}}_p">{knuckle}')


def test_an_invalid_source_inertial_is_recomputed_by_default(tmp_path: Path) -> None:
    """Issue 26: without `mass.inertials: recompute` the invalid inertial is replaced too (it used to stop the
    build), with one warning naming the link."""
    source = project(tmp_path)
    with_source_inertials(source, BAD_INERTIAL, GOOD_INERTIAL)
    result = CliRunner().invoke(main, ["build", "--config", str(source / "mini.yaml"), "--out", str(tmp_path / "o")])
    assert result.exit_code == 0, result.stderr
    warned = [line for line in result.stderr.splitlines() if "link right_hand_t: source inertial invalid" in line]
    assert len(warned) == 1 and "recomputed as a cylinder" in warned[0], result.stderr


def test_recompute_replaces_each_invalid_inertial_with_a_warning(tmp_path: Path) -> None:
    source = project(tmp_path)
    with_source_inertials(source, BAD_INERTIAL, GOOD_INERTIAL)
    edit(source / "mini.yaml", "  inertials: {}", "  inertials: recompute")
    warnings = build(source / "mini.yaml", tmp_path / "out")
    replaced = [line for line in warnings.splitlines() if "recomputed as a cylinder" in line]
    assert len(replaced) == 1 and "link right_hand_t: source inertial invalid" in replaced[0], warnings
    tree = urdf(tmp_path / "out")
    mass, tensor = inertia_of(tree, "right_hand_t")
    moments = np.linalg.eigvalsh(tensor)
    assert mass == 0.01  # the source's mass, its distribution from the geometry
    assert moments[0] > 0 and moments[0] + moments[1] >= moments[2]
    # The 1 x 1 x 2 cm box: the fitted cylinder runs along z, so z is the smallest moment.
    assert tensor[2, 2] < tensor[0, 0] == pytest.approx(tensor[1, 1])
    # A valid source inertial stays as written.
    mass, tensor = inertia_of(tree, "right_hand_p")
    assert mass == 0.01 and np.allclose(np.diag(tensor), [2e-6, 2e-6, 1e-6], rtol=0, atol=1e-15)


def test_recompute_of_one_link_replaces_it_even_when_valid(tmp_path: Path) -> None:
    source = project(tmp_path)
    with_source_inertials(source, GOOD_INERTIAL, GOOD_INERTIAL)
    edit(
        source / "mini.yaml", "  inertials: {}", "  inertials: {right_hand_p: recompute}\n  links: {right_hand_p: 0.03}"
    )
    edit(source / "mini.yaml", "  links: {}\n", "")
    warnings = build(source / "mini.yaml", tmp_path / "out")
    assert "link right_hand_p: source inertial replaced as configured" in warnings, warnings
    assert "right_hand_t" not in warnings
    tree = urdf(tmp_path / "out")
    mass, tensor = inertia_of(tree, "right_hand_p")
    assert mass == 0.03  # mass.links wins over the source's mass
    assert not np.allclose(np.diag(tensor), [2e-6, 2e-6, 1e-6], rtol=0, atol=1e-12)
    assert inertia_of(tree, "right_hand_t")[0] == 0.01


# --- python: paths --------------------------------------------------------------------------------------


def test_python_paths_find_an_installed_package(tmp_path: Path) -> None:
    import svhdesc

    found = resolve_path("python:svhdesc/compiler", tmp_path, "here")
    assert found == (Path(svhdesc.__file__).parent / "compiler").resolve()
    assert resolve_path("sub/x.urdf", tmp_path, "here") == (tmp_path / "sub" / "x.urdf").resolve()
    with pytest.raises(SvhdescError, match="here: python:no_such_module_h3/x: no installed Python package"):
        resolve_path("python:no_such_module_h3/x", tmp_path, "here")


# --- validate: what does not apply is skipped, not failed --------------------------------------------------


def test_validate_skips_the_coupling_checks_of_a_robot_without_couplings(tmp_path: Path) -> None:
    source = project(tmp_path)
    (source / "mini.yaml").write_text(NO_HAND)
    build(source / "mini.yaml", tmp_path / "out")
    report = tmp_path / "report.json"
    checks = "simulate,coupling_tracking,coupling_spec,limits,self_collision,semantics"
    args = ["validate", "--out", str(tmp_path / "out"), "--config", str(source / "mini.yaml"), "--checks", checks]
    result = CliRunner().invoke(main, [*args, "--json", str(report)])
    assert result.exit_code == 0, result.stdout + result.stderr
    statuses = {c["name"]: (c["status"], c["detail"]) for c in json.loads(report.read_text())["variants"][0]["checks"]}
    assert {n for n, (s, _) in statuses.items() if s == "skipped"} == {"coupling_tracking", "coupling_spec", "limits"}
    assert all(detail == "no couplings" for s, detail in statuses.values() if s == "skipped")
    assert all(s == "pass" for n, (s, _) in statuses.items() if n in {"simulate", "self_collision", "semantics"})
    assert "skipped (not applicable): coupling_tracking (no couplings)" in result.stdout
    assert "3 skipped as not applicable" in result.stdout


def test_a_check_that_could_not_run_still_fails() -> None:
    from svhdesc.validate.report import Check, VariantReport, not_run, skipped

    report = VariantReport("x", "x.urdf", "x.xml", [Check("simulate", "pass"), skipped("limits", "no couplings")])
    assert report.failed() == [] and [c.name for c in report.skipped] == ["limits"]
    report.checks.append(not_run("grasps", "the MJCF does not compile"))
    assert [c.name for c in report.failed()] == ["grasps"]


def test_get_and_the_loaders_take_a_built_folder(tmp_path: Path) -> None:
    import svhdesc

    source = project(tmp_path)
    (source / "mini.yaml").write_text(NO_HAND)
    build(source / "mini.yaml", tmp_path / "out")
    model = svhdesc.get(tmp_path / "out" / "mini")
    assert model.name == "mini" and model.mjcf_path == (tmp_path / "out" / "mini" / "mini.xml").resolve()
    assert svhdesc.load_mujoco(str(tmp_path / "out" / "mini")).nu == 2
    with pytest.raises(KeyError, match="unknown variant"):
        svhdesc.get(tmp_path / "out")  # a folder of variants is not a variant
