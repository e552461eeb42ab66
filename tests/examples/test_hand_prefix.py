"""The hand's prefix and side travel with the built model (its manifest's ``hand``, ``svhdesc.model.HandId``) and
nothing downstream guesses them from joint names: a left hand on the UR5 and a right hand named ``other_hand`` are
built, validated (the checks that find the hand), compared (report and joint plot) and run through the wire loop.

Seeded faults, each failing here: validate/handsim.find_hand taking ``right_hand`` instead of the built model's
prefix (other_hand: grasps and fingertip_force skip, "no SVH hand"); wireloop/mujoco_run.py's palm body back to
``right_hand_e1`` (both: no such body); compare/report.py's labels stripping only ``right_hand_``/``left_hand_``
(other_hand's rows keep the prefix); sim/robot.py describing the hand by ``right_hand`` (left: no hand channels).
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

HANDS = {  # variant -> (prefix, side)
    "ur5_svh_left": ("left_hand", "left"),
    "ur5_svh_other": ("other_hand", "right"),
}
ARM = ("shoulder_pan_joint", "shoulder_lift_joint", "elbow_joint", "wrist_1_joint", "wrist_2_joint", "wrist_3_joint")
CHECKS = "mass_budget,range_of_motion,load_limits,fingertip_force,grasps,collision_fidelity,contact_stability"


@pytest.fixture(scope="module")
def built(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The two variants, from a config extending this project's, built into one folder."""
    work = tmp_path_factory.mktemp("hands")
    base = yaml.safe_load((REPO / "config" / "svhdesc.yaml").read_text())["variants"]["ur5_svh_right"]
    variants = {
        name: {
            **base,
            "xacro": str(REPO / "xacro" / "ur5_svh.urdf.xacro"),
            "args": {"side": side, "prefix": prefix},
            "hand": {"prefix": prefix, "side": side},
        }
        for name, (prefix, side) in HANDS.items()
    }
    config = work / "hands.yaml"
    config.write_text(yaml.safe_dump({"extends": str(REPO / "config" / "svhdesc.yaml"), "variants": variants}))
    result = run_cli("build", "--config", str(config), "--out", str(work / "out"))
    assert result.returncode == 0, result.stderr
    return work / "out"


@pytest.mark.parametrize("variant", sorted(HANDS))
def test_the_built_model_carries_its_hand(built: Path, variant: str) -> None:
    prefix, side = HANDS[variant]
    model = get(built / variant)
    assert model.hand is not None and (model.hand.prefix, model.hand.side) == (prefix, side)
    joints = {j.get("name") for j in etree.parse(str(model.urdf_path)).iter("joint")}
    assert {f"{prefix}_{c}" for c in DRIVER_CHANNELS} <= joints
    manifest = json.loads((built / variant / "manifest.json").read_text())
    assert manifest["hand"] == {"prefix": prefix, "side": side}


def test_validate_finds_the_hand_under_any_prefix(built: Path, tmp_path: Path) -> None:
    """The hand checks run and pass on the other prefix (none skipped for want of a hand), and on the shipped
    svh_left (the shared full run of tests/validate) no hand check was skipped either."""
    report = tmp_path / "report.json"
    config = built.parent / "hands.yaml"
    result = run_cli(
        "validate", str(built / "ur5_svh_other"), "--config", str(config), "--checks", CHECKS, "--json", str(report)
    )
    checks = {c["name"]: c for c in json.loads(report.read_text())["variants"][0]["checks"]}
    assert result.returncode == 0, result.stdout[-3000:]
    assert set(CHECKS.split(",")) <= set(checks)
    assert all(c["status"] == "pass" for c in checks.values()), {n: c["status"] for n, c in checks.items()}
    assert "other_hand_* 1.3000/1.3 kg" in checks["mass_budget"]["value"]


def test_validate_on_svh_left_runs_every_hand_check(validated: Any) -> None:
    _, checks, _ = validated("svh_left")
    for name in ("range_of_motion", "fingertip_force", "grasps", "collision_fidelity"):
        assert checks[name]["status"] == "pass", (name, checks[name])


@pytest.mark.parametrize("variant", sorted(HANDS))
def test_compare_report_and_plot_name_the_hand(built: Path, variant: str, tmp_path: Path) -> None:
    from svhdesc.compare.report import markdown, plot
    from svhdesc.compare.runner import run_grid

    prefix, _ = HANDS[variant]
    folder = str(built / variant)
    setup, results = run_grid(folder, ["mujoco"], [None], 0.3)
    table = markdown(setup, results, folder)
    rows = [line.split("|")[1].strip() for line in table.splitlines() if line.startswith("| ")]
    assert "Pinky" in rows and not any(prefix in row for row in rows), rows
    hand_rows = [j for j in setup.actuated if j.startswith(f"{prefix}_")]
    assert len(hand_rows) == len(DRIVER_CHANNELS)
    paths = plot(results, tmp_path, folder)
    assert any(p.name.endswith("_joints.png") and p.stat().st_size > 0 for p in paths)


@pytest.mark.parametrize("variant", sorted(HANDS))
def test_the_wire_loop_runs_under_the_hand(built: Path, variant: str) -> None:
    from svhdesc.wireloop.env import UP, Environment
    from svhdesc.wireloop.mujoco_run import SceneConfig, execute, plan_targets
    from svhdesc.wireloop.wiremap import load_map

    env = Environment(load_map("training"))
    steps = env.path_cells[1:5]  # four moves along the wire from its start, the loop not turning
    poses = plan_targets(env, [cell << 2 for cell in steps], [UP] * len(steps))
    run, scene = execute(env.map, poses, SceneConfig(variant=str(built / variant)))
    assert run.actions == len(steps) and not run.touched_wire and run.other_wire_contacts == 0, run
    assert run.worst_position_error_m < 0.003, run
    prefix, _ = HANDS[variant]
    model = scene.model
    assert {model.body(model.geom_bodyid[g]).name for g in scene.ring} == {f"{prefix}_e1"}  # hung from the palm
    assert sorted(model.joint(model.actuator_trnid[a, 0]).name for a in scene.arm_actuators) == sorted(ARM)
