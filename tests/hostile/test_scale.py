"""Robots too big for a command are refused at once with the limit named (issue 48 item 6; ``core/limits.py``); the
walks over a tree are linear (the times: benchmarks/scale_bench.py, docs/results/scale.md).

Seeded faults: read_urdf without ``links_problem`` (init on 501 siblings writes a config); without
``depth_problem`` (init on the 251-deep chain writes a config, and build then fails past Python's recursion limit);
``unsimulated`` not called (the full tier simulates 129 joints for minutes, past the test's bound: the
in-process run is refused within 60 s); ``_on_cycles`` marking every link it walks as on a cycle (the link hanging
below the cycle, walked first, is named).
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

from svhdesc.core.limits import MAX_DEPTH, MAX_LINKS, MAX_SIMULATED_JOINTS, tree_depth
from svhdesc.validate.files import validate_file
from tests.support import REPO, fails_cleanly, run_cli

sys.path.insert(0, str(REPO / "benchmarks"))
from scale_bench import robot_urdf  # noqa: E402

CYCLE = """<?xml version="1.0"?>
<robot name="loop">
  <link name="e"/><link name="base"/><link name="a"/><link name="b"/><link name="c"/><link name="d"/>
  <joint name="j0" type="fixed"><parent link="base"/><child link="d"/></joint>
  <joint name="j1" type="fixed"><parent link="a"/><child link="b"/></joint>
  <joint name="j2" type="fixed"><parent link="b"/><child link="c"/></joint>
  <joint name="j3" type="fixed"><parent link="c"/><child link="a"/></joint>
  <joint name="j4" type="fixed"><parent link="c"/><child link="e"/></joint>
</robot>
"""


def test_tree_depth() -> None:
    assert tree_depth({}) == 1
    assert tree_depth({f"l{i}": f"l{i - 1}" for i in range(1, 10_001)}) == 10_001
    assert tree_depth({f"s{i}": "base" for i in range(1000)}) == 2
    assert tree_depth({"a": "b", "b": "c", "c": "a", "e": "c"}) == 4  # a cycle ends; its links count once


def test_a_cycle_names_its_own_links(tmp_path: Path) -> None:
    path = tmp_path / "loop.urdf"
    path.write_text(CYCLE)
    report = validate_file(path, {"structure"}, {}, tier="static")
    messages = [f.message for check in report.checks for f in check.findings]
    cycle = sorted(m.split("'")[1] for m in messages if "its own ancestor" in m)
    assert cycle == ["a", "b", "c"], messages


def test_init_refuses_a_tree_deeper_than_it_builds(tmp_path: Path) -> None:
    source = tmp_path / "deep.urdf"
    source.write_bytes(robot_urdf(MAX_DEPTH))  # base + MAX_DEPTH links: one too deep
    out = tmp_path / "out"
    out.mkdir()
    said = fails_cleanly(
        out, "init", str(source), "--out", str(out / "deep.yaml"), match=f"more than the {MAX_DEPTH} svhdesc builds"
    )
    assert f"{MAX_DEPTH + 1} links deep" in said


def test_init_refuses_more_links_than_it_builds(tmp_path: Path) -> None:
    source = tmp_path / "wide.urdf"
    source.write_bytes(robot_urdf(MAX_LINKS, siblings=True))  # base + MAX_LINKS links: one too many
    said = fails_cleanly(tmp_path, "init", str(source), "--out", str(tmp_path / "wide.yaml"), match="svhdesc builds")
    assert f"{MAX_LINKS + 1:,} links, more than the {MAX_LINKS}" in said


def test_the_full_tier_refuses_past_its_joints(tmp_path: Path) -> None:
    source = tmp_path / "wide.urdf"
    source.write_bytes(robot_urdf(MAX_SIMULATED_JOINTS + 1, siblings=True))
    started = time.perf_counter()
    fails_cleanly(None, "validate", str(source), "--tier", "full", match=f"more than the {MAX_SIMULATED_JOINTS}")
    assert time.perf_counter() - started < 60
    static = run_cli("validate", str(source), "--tier", "static", in_process=True)
    assert static.returncode == 0, static.stdout + static.stderr


def test_a_folder_s_big_model_is_a_finding_not_the_end(tmp_path: Path) -> None:
    """In a folder's walk (CI on a repository) the model past the full tier's joints is a finding naming the limit,
    and the other models are validated (seeded fault: the walk raising as a file given by name does: exit 2)."""
    (tmp_path / "wide.urdf").write_bytes(robot_urdf(MAX_SIMULATED_JOINTS + 1, siblings=True))
    (tmp_path / "small.urdf").write_bytes(robot_urdf(2))
    done = run_cli("validate", str(tmp_path), "--tier", "full", in_process=True)
    assert done.returncode == 1, done.stdout + done.stderr
    assert f"wide.urdf:1: mujoco_compile: {MAX_SIMULATED_JOINTS + 1} movable joints, more than" in done.stdout
    assert "2 model(s), 1 finding(s)" in done.stdout, done.stdout
