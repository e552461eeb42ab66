"""A hostile xacro bounded in time and memory (issue 48 item 5): xacro evaluates ``${...}`` as Python and expands
macros without bound, so a file can ask for a number of millions of digits, a string of 10 GB or a macro calling
itself twice at every level. The expansion runs in a forked child (``core/source/xacro.py``: ``bounded``) under a
time and an address-space limit; past either, one error naming the limit, and nothing hangs.

Seeded faults: ``bounded`` running ``work()`` in this process (the time cases run until the test's own 60 s guard
kills them: each case runs in a process of its own under that guard and 4 GiB; the memory case is a MemoryError
traceback; the child's pid is this one's), no RLIMIT_AS in the child (the limit the child reports is not its
parent's size plus 1 GiB).
"""

from __future__ import annotations

import os
import resource
import subprocess
import sys
import time
from pathlib import Path

import pytest

from svhdesc.core.source.xacro import bounded

HEAD = '<?xml version="1.0"?>\n<robot name="r" xmlns:xacro="http://www.ros.org/wiki/xacro">\n'
CASES = {
    # a number of 9**9**9: 370 million digits, minutes of CPU in one C call
    "power": '<xacro:property name="big" value="${9**9**9}"/>\n<link name="l${big}"/>\n',
    # a string of 10 GB
    "string": '<xacro:property name="big" value="${\'x\' * 10**10}"/>\n<link name="l${big}"/>\n',
    # a macro calling itself twice a level, 40 levels deep: 2**40 links
    "doubling": (
        '<xacro:macro name="two" params="n">\n'
        '  <xacro:if value="${n > 0}"><xacro:two n="${n - 1}"/><xacro:two n="${n - 1}"/></xacro:if>\n'
        '  <link name="l${n}"/>\n'
        "</xacro:macro>\n"
        '<xacro:two n="40"/>\n'
    ),
}
SCRIPT = """
import sys
from pathlib import Path
from svhdesc.core.source.xacro import expand_xacro
from svhdesc.errors import SvhdescError
try:
    expand_xacro(Path(sys.argv[1]), {}, {}, (int(sys.argv[2]), int(sys.argv[3])))
except SvhdescError as exc:
    print("error:", exc)
"""


def _guard() -> None:
    resource.setrlimit(resource.RLIMIT_AS, (4 << 30, 4 << 30))


def _expand(tmp_path: Path, case: str, seconds: int, memory: int) -> str:
    source = tmp_path / f"{case}.urdf.xacro"
    source.write_text(HEAD + CASES[case] + "</robot>\n")
    started = time.perf_counter()
    done = subprocess.run(
        [sys.executable, "-c", SCRIPT, str(source), str(seconds), str(memory)],
        capture_output=True,
        text=True,
        timeout=60,
        preexec_fn=_guard,
    )
    assert time.perf_counter() - started < 45, done
    assert done.returncode == 0, done.stderr[-2000:]
    return done.stdout


@pytest.mark.parametrize("case", ["power", "doubling"])
def test_an_expansion_past_its_time_is_stopped(tmp_path: Path, case: str) -> None:
    said = _expand(tmp_path, case, 3, 1 << 30)
    assert said.startswith("error: ") and f"{case}.urdf.xacro: xacro: stopped at its limit of 3 s" in said, said


def test_an_expansion_past_its_memory_is_stopped(tmp_path: Path) -> None:
    said = _expand(tmp_path, "string", 30, 1 << 30)
    assert said.startswith("error: ") and "string.urdf.xacro: xacro: out of memory at its limit of 1 GiB" in said


def test_the_cli_answers_one_line(tmp_path: Path) -> None:
    """`svhdesc validate` on the 10 GB string, as CI runs it: one error line, exit 2, within the default limits."""
    source = tmp_path / "string.urdf.xacro"
    source.write_text(HEAD + CASES["string"] + "</robot>\n")
    done = subprocess.run(
        [sys.executable, "-m", "svhdesc.cli", "validate", str(source), "--tier", "static"],
        capture_output=True,
        text=True,
        timeout=60,
        preexec_fn=_guard,
    )
    assert done.returncode == 2, (done.stdout, done.stderr)
    assert done.stderr.startswith("error: ") and "out of memory at its limit of 2 GiB" in done.stderr, done.stderr
    assert "Traceback" not in done.stderr


def _own_limit() -> tuple[int, int]:
    return os.getpid(), resource.getrlimit(resource.RLIMIT_AS)[0]


def test_the_child_is_bounded() -> None:
    """The work runs in another process whose address space is its parent's size plus the limit given."""
    with open("/proc/self/status") as status:
        size = int(next(line.split()[1] for line in status if line.startswith("VmSize:"))) << 10
    pid, limit = bounded(_own_limit, "test", 10, 1 << 30)
    assert pid != os.getpid()
    assert size + (1 << 30) - (256 << 20) < limit < size + (1 << 30) + (256 << 20), (size, limit)
