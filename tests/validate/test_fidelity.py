"""The checks against the real hand: range_of_motion (every channel end to end, contacts and gravity on) and
collision_fidelity (collision geometry touches only where the vendor's parts do), with their seeded faults."""

from __future__ import annotations

import json
import shutil
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from svhdesc.validate.collision_fidelity import check_collision_fidelity
from svhdesc.validate.options import Options
from svhdesc.validate.pair import load_pair
from svhdesc.validate.range_of_motion import check_range_of_motion
from tests.support import REPO, VARIANTS, VENDOR_SVH, run_cli

GENERATED = REPO / "generated"
OPTIONS = Options(vendor_meshes=VENDOR_SVH)
needs_vendor = pytest.mark.skipif(
    not (VENDOR_SVH / "description" / "urdf" / "svh.urdf.xacro").is_file(),
    reason=f"vendor meshes not found at {VENDOR_SVH}",
)


def pair_of(directory: Path):
    return load_pair(directory / f"{directory.name}.urdf", directory / f"{directory.name}.xml")


def inflated_bracket(tmp_path: Path, factor: float = 1.3) -> Path:
    """A copy of svh_right whose ring-finger bracket hull nearest the middle one is scaled about its centroid."""
    import mujoco

    target = tmp_path / "svh_right"
    shutil.copytree(GENERATED / "svh_right", target)
    model = pair_of(target).model
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    ring, middle = (model.body(f"right_hand_virtual_{s}").id for s in "jk")
    geoms = [g for g in range(model.ngeom) if model.geom_bodyid[g] == ring and model.geom_contype[g]]
    others = [g for g in range(model.ngeom) if model.geom_bodyid[g] == middle and model.geom_contype[g]]
    nearest = min(geoms, key=lambda g: min(mujoco.mj_geomDistance(model, data, g, o, 0.05, None) for o in others))
    mesh = model.mesh(int(model.geom_dataid[nearest])).name
    path = target / "assets" / f"{mesh}.obj"
    lines = path.read_text().splitlines()
    vertices = np.array([[float(v) for v in line.split()[1:4]] for line in lines if line.startswith("v ")])
    scaled = iter(vertices.mean(axis=0) + factor * (vertices - vertices.mean(axis=0)))
    path.write_text(
        "\n".join("v " + " ".join(repr(float(x)) for x in next(scaled)) if ln.startswith("v ") else ln for ln in lines)
        + "\n"
    )
    return target


@pytest.mark.parametrize("variant", VARIANTS)
def test_every_channel_reaches_both_ends_with_contacts_on(variant: str, validated: Callable[[str], Any]) -> None:
    """The range_of_motion check of the variant's full validate run (its figures from the JSON, its table as
    printed)."""
    result, checks, _ = validated(variant)
    check = checks["range_of_motion"]
    assert check["status"] == "pass", check["detail"]
    channels = check["data"]["channels"]
    assert len(channels) == 9
    for name, entry in channels.items():
        low, high = entry["range"]
        assert entry["fraction"] > 0.98, name
        assert abs(entry["reached"][1] - high) <= 0.01 * (high - low), name
        for follower, reached in entry["followers"].items():
            assert set(reached) == {"start", "upper", "lower"}, follower
    table = result.stdout.split("\nrange_of_motion:\n", 1)[1].split("\n\n", 1)[0]
    assert "Thumb_Opposition" in table


def test_inflated_palm_hull_fails_range_of_motion_naming_channel_and_pair(tmp_path: Path) -> None:
    (check,) = check_range_of_motion(pair_of(inflated_bracket(tmp_path)), OPTIONS)
    assert check.status == "fail"
    assert "Thumb_Opposition stops at" in check.detail
    assert "right_hand_virtual_k/right_hand_virtual_j" in check.detail
    blocked = check.data["channels"]["right_hand_Thumb_Opposition"]["blocked_by"]["upper"]
    assert blocked[0] == "right_hand_virtual_k/right_hand_virtual_j"


@needs_vendor
@pytest.mark.parametrize("variant", VARIANTS)
def test_collision_fidelity_is_empty(variant: str, validated: Callable[[str], Any]) -> None:
    """Issue 15's rule: no pair deeper than 0.5 mm while the vendor parts stay more than 1 mm apart, in any variant
    (the check of the variant's full validate run)."""
    check = validated(variant)[1]["collision_fidelity"]
    data = check["data"]
    assert data["poses"] > 100 and data["judged_pairs"], check["detail"]
    assert data["depth_m"] == 0.5e-3 and data["gap_m"] == 1e-3
    assert data["findings"] == [], check["detail"]
    assert check["status"] == "pass", check["detail"]


@needs_vendor
def test_inflated_palm_hull_appears_in_collision_fidelity(tmp_path: Path) -> None:
    # Scaled 1.5 (1.3 stays under the 0.5 mm depth rule: range_of_motion catches that one, the test above).
    (check,) = check_collision_fidelity(pair_of(inflated_bracket(tmp_path, 1.5)), OPTIONS)
    assert check.status == "fail"
    bodies = [f["bodies"] for f in check.data["findings"]]
    assert ["right_hand_virtual_k", "right_hand_virtual_j"] in bodies
    finding = check.data["findings"][bodies.index(["right_hand_virtual_k", "right_hand_virtual_j"])]
    assert finding["vendor_gap_mm"] > 1.0 and finding["depth_mm"] > 0.5


def test_missing_vendor_meshes_are_reported_not_skipped_silently(tmp_path: Path) -> None:
    source = GENERATED / "svh_right"
    report = tmp_path / "report.json"
    args = ["validate", "--urdf", str(source / "svh_right.urdf"), "--mjcf", str(source / "svh_right.xml")]
    args += ["--checks", "collision_fidelity", "--json", str(report), "--vendor-meshes", str(tmp_path)]
    result = run_cli(*args)
    assert result.returncode == 1
    assert "skipped: vendor meshes not found" in result.stdout
    (check,) = json.loads(report.read_text())["variants"][0]["checks"]
    assert check["status"] == "not run" and check["missing_tool"] == "vendor meshes"


@needs_vendor
@pytest.mark.parametrize("fraction, overlapping", [(0.5, True), (0.95, True), (0.3, False)])
def test_all_channels_at_once_jam_the_real_fingers_too(fraction: float, overlapping: bool) -> None:
    """README: with every channel at 50 % or 95 % of its range the vendor parts of neighbouring fingers meet (so the
    real hand cannot take that pose either); at 30 % they are apart."""
    import mujoco

    from svhdesc.model import actuated_joints, couplings
    from svhdesc.validate.collision_fidelity import _frame, base_qpos, place
    from svhdesc.validate.vendor_geometry import vendor_links

    model = pair_of(GENERATED / "svh_right").model
    data = mujoco.MjData(model)
    pose = {n: lo + fraction * (hi - lo) for n, (lo, hi) in actuated_joints(model).items()}
    place(model, data, base_qpos(model), pose, couplings(model))
    vendor = vendor_links(VENDOR_SVH.resolve(), "right")
    fingers = [("l", "p", "t"), ("k", "o", "s"), ("j", "n", "r"), ("i", "m", "q")]
    gaps = []
    for one, other in zip(fingers, fingers[1:]):  # neighbouring fingers, every segment against every segment
        for a in one:
            for b in other:
                ida, idb = model.body(f"right_hand_{a}").id, model.body(f"right_hand_{b}").id
                transform = np.linalg.inv(_frame(data, idb)) @ _frame(data, ida)
                gaps.append(vendor[a].distance(vendor[b], transform))
    assert (min(gaps) < 5e-5) == overlapping, min(gaps)
