"""benchmarks/consumers.py: a file an engine cannot read is one row naming the engine, the file and the reason (never
a skipped row); a run that loads shows what it kept against the reference. The broken copies are broken for the
engine that matters most, MuJoCo itself (read in this process), and the rows render what a run reports.

Seeded faults, each failing here: ``row`` dropping the error (a blank "loads" cell); ``broken_files`` writing the
MJCF unchanged (MuJoCo reads it)."""

from __future__ import annotations

from pathlib import Path

import mujoco
import pytest

from svhdesc.loaders.track import Run, run, run_mujoco, servo_plan
from tests.benchmarks.scripts import load

consumers = load("consumers")


def test_a_run_that_fails_is_one_row_with_its_reason() -> None:
    reference = Run("mujoco", "4.0.0", "mjcf", "MuJoCo C")
    failed = Run("newton", "1.8.0", "usd", "featherstone", error="ErrorException: cut.usda:2371: parse error")
    row = consumers.row("svh_right", consumers.CONSUMERS[3], failed, reference)
    assert len(row) == len(consumers.COLUMNS)
    assert row[1:6] == ["Newton", "1.8.0", "Featherstone (Warp CPU)", "usd", "no: " + failed.error]
    assert set(row[6:]) == {"-"}


def test_a_run_that_loads_shows_what_it_kept() -> None:
    import svhdesc

    mjcf = str(svhdesc.get("svh_right").mjcf_path)
    plan = servo_plan(mjcf)
    reference = run_mujoco(mjcf, plan, seconds=0.05)
    row = consumers.row("svh_right", consumers.CONSUMERS[0], reference, reference)
    assert row[5:10] == ["yes", "20", "11 of 11", "1.3000 (+0.000 %)", "0"]


def test_the_broken_copies_are_refused_with_one_line(tmp_path: Path) -> None:
    broken = consumers.broken_files(tmp_path, "svh_right")
    assert sorted(broken) == ["mjcf", "urdf", "usd"]
    with pytest.raises(ValueError, match="unknown element 'no_such_right_hand_j5' in equality"):
        mujoco.MjModel.from_xml_path(str(broken["mjcf"]))
    import svhdesc

    plan = servo_plan(str(svhdesc.get("svh_right").mjcf_path))
    refused = run("mujoco", "mjcf", str(broken["mjcf"]), plan, "MuJoCo C", seconds=0.0)
    assert refused.error and refused.error.startswith("ValueError: ") and "\n" not in refused.error
    assert "no_such_right_hand_j5" in refused.error and refused.engine == "mujoco" and refused.file == "mjcf"
    assert "no_such_link" in broken["urdf"].read_text()
    from pxr import Sdf

    with pytest.raises(Exception, match="parse error"):
        Sdf.Layer.FindOrOpen(str(broken["usd"]))
