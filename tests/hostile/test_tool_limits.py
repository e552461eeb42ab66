"""The external tools validate starts (check_urdf, ign sdf) run under a time and a memory limit; over either, the
check fails with the limit named, and nothing hangs or takes the machine (issue 48: `ign sdf` on a 10,000-link
chain grew past 8 GB). Seeded faults: no preexec_fn (the allocation succeeds: exit 0), no TimeoutExpired handler
(the test gets the exception)."""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

from svhdesc.validate import parsers


def test_a_tool_over_the_memory_limit_fails_naming_it(tmp_path: Path) -> None:
    greedy = [sys.executable, "-c", f"bytearray({(parsers.MEMORY_LIMIT * 2)})"]
    result = parsers._run(greedy, tmp_path)
    assert result.returncode != 0 and f"limit of {parsers.MEMORY_LIMIT >> 30} GiB" in result.stderr


def test_a_tool_over_the_time_limit_is_stopped_naming_it(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(parsers, "TIMEOUT", 1)
    result = parsers._run([sys.executable, "-c", "import time; time.sleep(30)"], tmp_path)
    assert result.returncode == -9 and "time limit of 1 s" in result.stderr
