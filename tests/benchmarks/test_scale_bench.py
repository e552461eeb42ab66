"""benchmarks/scale_bench.py as a smoke run on tiny robots (the times are the benchmark's, never a test's): every
command runs and says ok on a 2-link chain, and the robots it writes are what it says (a chain hangs each link on
the one before, siblings all hang on the base).

Seeded faults: siblings hung on the link before (the shape test fails); a command's outcome read from its stdout only
(the refusal's error line, on stderr, is lost: the refused robot's row has no 'error:').
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest
from lxml import etree

from svhdesc.core.limits import MAX_LINKS
from tests.benchmarks.scripts import BENCHMARKS, REPO, load


def test_the_robots_are_chains_and_siblings() -> None:
    bench = load("scale_bench")
    for siblings in (False, True):
        root = etree.fromstring(bench.robot_urdf(5, siblings))
        parents = [j.find("parent").get("link") for j in root.iter("joint")]
        assert parents == (["base"] * 5 if siblings else ["base", "link1", "link2", "link3", "link4"])


@pytest.mark.slow
def test_a_smoke_run(tmp_path: Path) -> None:
    """A 2-link chain through init, build and both tiers, and one robot init refuses, with its limit in the row."""
    done = subprocess.run(
        [
            sys.executable,
            str(BENCHMARKS / "scale_bench.py"),
            "--sizes",
            "2",
            "--siblings",
            str(MAX_LINKS),
            "--out",
            str(tmp_path),
            "--no-page",
        ],
        capture_output=True,
        text=True,
        timeout=300,
        cwd=REPO,
    )
    assert done.returncode == 0, done.stderr[-3000:]
    rows = [line.split() for line in done.stdout.splitlines() if line.strip()]
    chain = [row for row in rows if row[0] == "chain_2"]
    assert [row[1] for row in chain] == ["init", "build", "validate", "validate"]
    assert all("ok" in row for row in chain), done.stdout
    refused = next(row for row in rows if row[0] == f"siblings_{MAX_LINKS}" and row[1] == "init")
    assert "error:" in refused and f"{MAX_LINKS}" in " ".join(refused[4:]), refused
