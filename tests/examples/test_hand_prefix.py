"""The hand's prefix and side travel with the built model (its manifest's ``hand``, ``svhdesc.model.HandId``) and
nothing downstream guesses them from joint names: the shipped ``svh_left`` and a UR5 carrying a left hand named
``other_hand`` (one build: another prefix and the other side at once) are validated (the checks that find the hand),
compared (report and joint plot) and, the one with an arm, run through the wire loop.

Seeded faults, each failing here: validate/handsim.find_hand taking ``right_hand`` instead of the built model's
prefix (fingertip_force skips, "no SVH hand"); collision_fidelity taking the right hand's vendor parts (the left
hand's pairs are judged against the wrong side: hundreds of pairs); wireloop/mujoco_run.py's palm body back to
``right_hand_e1`` (no such body); compare/report.py's labels stripping only ``right_hand_``/``left_hand_`` (the rows
keep ``other_hand_``); sim/robot.py describing the hand by ``right_hand`` (no hand channels, the compare setup
finds no channel).
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest
import yaml
from lxml import etree

from svhdesc.model import DRIVER_CHANNELS, get
from tests.support import REPO, run_cli

pytestmark = pytest.mark.slow

VARIANT, PREFIX, SIDE = "ur5_svh_other", "other_hand", "left"
ARM = ("shoulder_pan_joint", "shoulder_lift_joint", "elbow_joint", "wrist_1_joint", "wrist_2_joint", "wrist_3_joint")
# The checks that find the hand by its prefix (grasps finds it as fingertip_force does, and takes 30 s more).
CHECKS = "mass_budget,range_of_motion,load_limits,fingertip_force,collision_fidelity,contact_stability"


@pytest.fixture(scope="module")
def built(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """ur5_svh_right's variant with the left hand named other_hand, from a config extending this project's."""
    work = tmp_path_factory.mktemp("hands")
    variant = yaml.safe_load((REPO / "config" / "svhdesc.yaml").read_text())["variants"]["ur5_svh_right"]
    variant.update(
        xacro=str(REPO / "xacro" / "ur5_svh.urdf.xacro"),
        args={"side": SIDE, "prefix": PREFIX},
        hand={"prefix": PREFIX, "side": SIDE},
    )
    config = work / "hands.yaml"
    config.write_text(
        yaml.safe_dump({"extends": str(REPO / "config" / "svhdesc.yaml"), "variants": {VARIANT: variant}})
    )
    result = run_cli("build", "--config", str(config), "--out", str(work / "out"), in_process=True)
    assert result.returncode == 0, result.stderr
    return work / "out" / VARIANT


def test_the_built_model_carries_its_hand(built: Path) -> None:
    model = get(built)
    assert model.hand is not None and (model.hand.prefix, model.hand.side) == (PREFIX, SIDE)
    assert json.loads((built / "manifest.json").read_text())["hand"] == {"prefix": PREFIX, "side": SIDE}
    joints = {j.get("name") for j in etree.parse(str(model.urdf_path)).iter("joint")}
    assert {f"{PREFIX}_{c}" for c in DRIVER_CHANNELS} <= joints
    assert get("svh_left").hand is not None and (get("svh_left").hand.prefix, get("svh_left").hand.side) == (
        "left_hand",
        "left",
    )


def test_validate_finds_the_hand_under_another_prefix(built: Path, tmp_path: Path) -> None:
    """Every check that finds the hand runs and passes (none skipped for want of a hand); collision_fidelity judges
    the left hand against the vendor's left parts."""
    report = tmp_path / "report.json"
    config = built.parent.parent / "hands.yaml"
    args = ("validate", str(built), "--config", str(config), "--checks", CHECKS, "--json", str(report))
    result = run_cli(*args, in_process=True)
    checks = {c["name"]: c for c in json.loads(report.read_text())["variants"][0]["checks"]}
    assert set(checks) == set(CHECKS.split(","))
    assert all(c["status"] == "pass" for c in checks.values()), result.stdout[-4000:]
    assert f"{PREFIX}_* 1.3000/1.3 kg" in checks["mass_budget"]["value"]


@pytest.mark.parametrize("variant", ["svh_left"])
def test_validate_on_svh_left_runs_every_hand_check(validated: Any, variant: str) -> None:
    """The shared full run of the shipped left hand (tests/conftest.py ``validated``): no hand check skipped."""
    _, checks, _ = validated(variant)
    for name in ("range_of_motion", "fingertip_force", "grasps", "collision_fidelity", "contact_stability"):
        assert checks[name]["status"] == "pass", (name, checks[name])


@pytest.mark.parametrize("which", ["svh_left", VARIANT])
def test_compare_report_and_plot_name_the_hand(built: Path, which: str, tmp_path: Path) -> None:
    from svhdesc.compare.report import markdown, plot
    from svhdesc.compare.runner import run_grid

    variant = which if which == "svh_left" else str(built)
    prefix = get(variant).hand.prefix
    setup, results = run_grid(variant, ["mujoco"], [None], 0.3)
    assert {f"{prefix}_{c}" for c in DRIVER_CHANNELS} <= set(setup.actuated)
    table = markdown(setup, results, variant).splitlines()
    rows = [line.split("|")[1].strip() for line in table if line.startswith("| ")]
    assert set(DRIVER_CHANNELS) <= set(rows) and not any(prefix in row for row in rows), rows
    paths = plot(results, tmp_path, variant)
    assert any(p.name.endswith("_joints.png") and p.stat().st_size > 0 for p in paths)


def test_the_wire_loop_runs_under_the_hand(built: Path) -> None:
    from svhdesc.wireloop.env import UP, Environment
    from svhdesc.wireloop.mujoco_run import SceneConfig, execute, plan_targets
    from svhdesc.wireloop.wiremap import load_map

    env = Environment(load_map("training"))
    steps = env.path_cells[1:5]  # four moves along the wire from its start, the loop not turning
    poses = plan_targets(env, [cell << 2 for cell in steps], [UP] * len(steps))
    run, scene = execute(env.map, poses, SceneConfig(variant=str(built)))
    assert run.actions == len(steps) and not run.touched_wire and run.other_wire_contacts == 0, run
    assert run.worst_position_error_m < 0.003, run
    model = scene.model
    assert {model.body(model.geom_bodyid[g]).name for g in scene.ring} == {f"{PREFIX}_e1"}  # hung from the palm
    assert sorted(model.joint(model.actuator_trnid[a, 0]).name for a in scene.arm_actuators) == sorted(ARM)
