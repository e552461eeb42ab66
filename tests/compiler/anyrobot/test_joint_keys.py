"""joints.NAME.{damping,friction}, simulation.friction_cap and .cone, collision.exclude on a two-link robot.

Seeded faults: dropping the friction cap (frictionloss 8 stays: test_friction_capped fails); replacing the
source's damping by the arm default again (test_source_damping_kept fails); ignoring collision.exclude
(the excluded pair is missing from the MJCF)."""

from __future__ import annotations

from pathlib import Path

import mujoco
import pytest

from tests.support import run_cli

URDF = """<robot name="two">
  <link name="a"><inertial><mass value="1"/>
    <inertia ixx="0.01" iyy="0.01" izz="0.01" ixy="0" ixz="0" iyz="0"/></inertial>
    <collision><geometry><box size="0.1 0.1 0.1"/></geometry></collision></link>
  <link name="b"><inertial><mass value="0.5"/>
    <inertia ixx="0.01" iyy="0.01" izz="0.01" ixy="0" ixz="0" iyz="0"/></inertial>
    <collision><origin xyz="0 0 0.3"/><geometry><box size="0.05 0.05 0.2"/></geometry></collision></link>
  <link name="c"><inertial><mass value="0.2"/>
    <inertia ixx="0.01" iyy="0.01" izz="0.01" ixy="0" ixz="0" iyz="0"/></inertial>
    <collision><origin xyz="0 0 0.3"/><geometry><box size="0.05 0.05 0.2"/></geometry></collision></link>
  <joint name="j1" type="revolute"><parent link="a"/><child link="b"/><origin xyz="0 0 0.1"/><axis xyz="0 1 0"/>
    <limit lower="-1" upper="1" effort="20" velocity="1"/><dynamics damping="2" friction="8"/></joint>
  <joint name="j2" type="revolute"><parent link="b"/><child link="c"/><origin xyz="0 0 0.5"/><axis xyz="0 1 0"/>
    <limit lower="-1" upper="1" effort="10" velocity="1"/><dynamics damping="1" friction="0.5"/></joint>
</robot>
"""


def _write(tmp_path: Path, extra: str) -> None:
    """two.yaml: ``extra`` plus the arm and collision sections it does not write itself."""
    base = {"arm": "arm: {enabled: true, joints: [j1, j2]}\n", "collision": "collision: {mode: hull}\n"}
    text = "".join(v for k, v in base.items() if f"{k}:" not in extra) + "variants: {two: {xacro: two.urdf}}\n"
    (tmp_path / "two.yaml").write_text(text + extra)


def _build(tmp_path: Path, extra: str) -> tuple[object, str]:
    (tmp_path / "two.urdf").write_text(URDF)
    _write(tmp_path, extra)
    result = run_cli("build", "--config", str(tmp_path / "two.yaml"), "--out", str(tmp_path / "out"), in_process=True)
    assert result.returncode == 0, result.stderr
    return mujoco.MjModel.from_xml_path(str(tmp_path / "out" / "two" / "two.xml")), result.stderr


def test_friction_capped_and_source_damping_kept(tmp_path: Path) -> None:
    model, stderr = _build(tmp_path, "")
    assert model.dof_frictionloss.tolist() == pytest.approx([2.0, 0.5])  # 0.1 x 20 N m; 0.5 is below 0.1 x 10
    assert model.dof_damping.tolist() == pytest.approx([2.0, 1.0])
    warned = [line for line in stderr.splitlines() if "friction" in line]
    assert len(warned) == 1 and "joint j1" in warned[0]


def test_overrides_and_options(tmp_path: Path) -> None:
    model, _ = _build(
        tmp_path,
        "joints: {j1: {friction: 8.0, damping: 0.3}}\nsimulation: {cone: pyramidal, friction_cap: 1.0}\n"
        "collision: {mode: hull, exclude: [[a, c]]}\n",
    )
    assert model.dof_frictionloss.tolist() == pytest.approx([8.0, 0.5])
    assert model.dof_damping.tolist() == pytest.approx([0.3, 1.0])
    assert model.opt.cone == mujoco.mjtCone.mjCONE_PYRAMIDAL
    excluded = {(model.body(s >> 16).name, model.body(s & 0xFFFF).name) for s in model.exclude_signature}
    assert ("a", "c") in excluded


def test_arm_damping_written_wins(tmp_path: Path) -> None:
    model, _ = _build(tmp_path, "arm: {enabled: true, joints: [j1, j2], joint_damping: 4.0}\n")
    assert model.dof_damping.tolist() == pytest.approx([4.0, 4.0])


@pytest.mark.parametrize(
    ("extra", "message"),
    [
        ("joints: {j9: {damping: 1.0}}\n", "joints.j9"),
        ("joints: {j1: {stiffness: 1.0}}\n", "stiffness"),
        ("simulation: {cone: round}\n", "cone"),
        ("collision: {mode: hull, exclude: [[a, zz]]}\n", "zz"),
        ("collision: {mode: hull, exclude: [a]}\n", "collision.exclude"),
    ],
)
def test_bad_keys(tmp_path: Path, extra: str, message: str) -> None:
    (tmp_path / "two.urdf").write_text(URDF)
    _write(tmp_path, extra)
    result = run_cli("build", "--config", str(tmp_path / "two.yaml"), "--out", str(tmp_path / "out"), in_process=True)
    assert result.returncode == 2
    errors = [line for line in result.stderr.splitlines() if line.startswith("error:")]
    assert len(errors) == 1 and message in errors[0] and "Traceback" not in result.stderr, result.stderr
