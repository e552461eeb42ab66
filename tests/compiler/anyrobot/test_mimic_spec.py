"""<mimic> tags as the coupling spec (spec_from_mimics). Seeded faults: composing a chain as
multiplier * offset instead of multiplier * leader_offset + offset fails test_chain; skipping the leader's
limit check lets a channel of range [0, 0] through (test_leader_without_limits); keeping the <mimic> of a fixed joint
(Talos' gripper) put it into the spec, which the build then refused ('unknown joint ... (coupled joint)')."""

from __future__ import annotations

import warnings
from pathlib import Path

import pytest
from lxml import etree

from svhdesc.core.settings.coupling import spec_from_mimics
from svhdesc.core.source.urdf import read_mimics, read_urdf
from svhdesc.errors import SvhdescError


def _robot(tmp_path: Path, leader_limit: str) -> tuple[object, list]:
    text = (
        '<robot name="g"><link name="a"/><link name="b"/><link name="c"/><link name="d"/>'
        f'<joint name="drive" type="revolute"><parent link="a"/><child link="b"/>{leader_limit}</joint>'
        '<joint name="f1" type="revolute"><parent link="a"/><child link="c"/><limit lower="-9" upper="9" '
        'effort="1" velocity="1"/><mimic joint="drive" multiplier="2" offset="0.1"/></joint>'
        '<joint name="f2" type="revolute"><parent link="a"/><child link="d"/><limit lower="-9" upper="9" '
        'effort="1" velocity="1"/><mimic joint="f1" multiplier="-1" offset="0.5"/></joint></robot>'
    )
    path = tmp_path / "g.urdf"
    path.write_text(text)
    root = etree.parse(str(path)).getroot()
    return read_urdf(root, {}, path), read_mimics(root, path)


def test_chain_is_composed_onto_the_first_leader(tmp_path: Path) -> None:
    robot, mimics = _robot(tmp_path, '<limit lower="0" upper="1" effort="3" velocity="2"/>')
    spec = spec_from_mimics(robot, mimics, tmp_path / "g.urdf")  # type: ignore[arg-type]
    assert spec is not None
    assert [(c.name, c.lower, c.upper, c.effort, c.velocity) for c in spec.channels] == [("drive", 0, 1, 3, 2)]
    coeffs = {c.joint: (c.channel, c.coeffs) for c in spec.couplings}
    # f2 = -1 * (2 * drive + 0.1) + 0.5 = -2 * drive + 0.4
    assert coeffs["f1"] == ("drive", (0.1, 2.0))
    assert coeffs["f2"][0] == "drive" and coeffs["f2"][1] == pytest.approx((0.4, -2.0))


def test_leader_without_limits(tmp_path: Path) -> None:
    robot, mimics = _robot(tmp_path, '<limit lower="0" upper="1" effort="0" velocity="2"/>')
    with pytest.raises(SvhdescError, match="joint drive leads <mimic> joints"):
        spec_from_mimics(robot, mimics, tmp_path / "g.urdf")  # type: ignore[arg-type]
    with pytest.raises(SvhdescError, match="joint drive: its limits give it no range"):
        _robot(tmp_path, "")  # no <limit>: reading names the joint and the settings that give it limits


def test_mimic_on_a_fixed_joint_is_ignored_with_one_warning(tmp_path: Path) -> None:
    """Talos draws its gripper's linkage as fixed joints with <mimic> tags (for Gazebo's mimic plugin): they move
    nothing, so they stay out of the spec, named in one warning line."""
    text = (
        '<robot name="g"><link name="a"/><link name="b"/><link name="c"/><link name="d"/>'
        '<joint name="drive" type="revolute"><parent link="a"/><child link="b"/>'
        '<limit lower="0" upper="1" effort="3" velocity="2"/></joint>'
        '<joint name="f1" type="revolute"><parent link="a"/><child link="c"/><limit lower="-9" upper="9" '
        'effort="1" velocity="1"/><mimic joint="drive"/></joint>'
        '<joint name="frozen" type="fixed"><parent link="a"/><child link="d"/><mimic joint="drive"/></joint></robot>'
    )
    path = tmp_path / "g.urdf"
    path.write_text(text)
    root = etree.parse(str(path)).getroot()
    robot, mimics = read_urdf(root, {}, path), read_mimics(root, path)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        spec = spec_from_mimics(robot, mimics, path)
    assert spec is not None and [c.joint for c in spec.couplings] == ["f1"]
    assert len(caught) == 1 and "<mimic> on 1 fixed joint(s) ignored" in str(caught[0].message)
    assert "frozen" in str(caught[0].message)
