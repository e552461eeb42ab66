"""tools/install.sh waits for apt's locks (held by unattended-upgrades on a fresh VM) instead of failing with 100.

The real script runs in its dry-run mode (every step but the commands themselves) against a lock file of the
test's own, held the way apt and dpkg hold theirs: an fcntl write lock.
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path

import pytest

from tests.support import REPO

HOLD = (
    "import fcntl, sys, time\n"
    "f = open(sys.argv[1], 'w'); fcntl.lockf(f, fcntl.LOCK_EX)\n"
    "print('held', flush=True); time.sleep(float(sys.argv[2]))\n"
)


@pytest.fixture
def held_lock(tmp_path: Path) -> Iterator[tuple[Path, subprocess.Popen[str], float]]:
    """A lock file held for 2 s by another process: (path, the holder, time it took the lock)."""
    lock = tmp_path / "lock-frontend"
    lock.touch()
    holder = subprocess.Popen([sys.executable, "-c", HOLD, str(lock), "2"], stdout=subprocess.PIPE, text=True)
    assert holder.stdout is not None and holder.stdout.readline() == "held\n"
    taken = time.monotonic()
    yield lock, holder, taken
    holder.kill()
    holder.wait()


def install(lock: Path, wait: int = 600, *args: str) -> tuple[subprocess.CompletedProcess[str], float]:
    env = {**os.environ, "SVHDESC_APT_LOCKS": f"{lock.parent / 'no-such-lock'}:{lock}", "SVHDESC_APT_POLL": "0.1"}
    env["SVHDESC_APT_WAIT"] = str(wait)
    result = subprocess.run(
        ["bash", str(REPO / "tools" / "install.sh"), "--dry-run", *args],
        capture_output=True,
        text=True,
        env=env,
        timeout=60,
    )
    return result, time.monotonic()


def test_waits_for_a_held_lock_then_installs(held_lock: tuple[Path, subprocess.Popen[str], float]) -> None:
    lock, holder, taken = held_lock
    result, ended = install(lock)
    assert result.returncode == 0, result.stderr
    lines = result.stderr.splitlines()
    # It says what it waits for and who holds it...
    assert f"install.sh: waiting for {lock}, held by PID {holder.pid} ({sys.executable} -c" in lines[0]
    assert holder.wait(timeout=5) == 0  # the holder ran its full 2 s: it was not killed to make way
    assert ended - taken >= 2.0  # ...waits until the lock is free...
    assert lines[1].startswith("install.sh: apt is free after")
    # ...then goes on with apt, which itself waits for the lock too (a race between the look and apt).
    assert lines[2].startswith("install.sh: [0:0") and "Debian packages" in lines[2]
    assert lines[3] == "+ apt-get -o DPkg::Lock::Timeout=600 update -qq"
    assert lines[4].startswith("+ apt-get -o DPkg::Lock::Timeout=600 install -y -qq --no-install-recommends python3 ")
    assert lines[-2] == "+ .venv/bin/python -m pip install -q -c constraints.txt -e .[build]"


def test_a_free_lock_is_not_waited_for(tmp_path: Path) -> None:
    lock = tmp_path / "lock-frontend"
    lock.touch()
    result, _ = install(lock, 600, "test")
    assert result.returncode == 0, result.stderr
    assert "waiting" not in result.stderr
    assert "\n+ apt-get -o DPkg::Lock::Timeout=600 update -qq\n" in result.stderr
    assert "liburdfdom-tools" in result.stderr and "-e .[test]" in result.stderr


def test_gives_up_after_its_wait_naming_the_holder(held_lock: tuple[Path, subprocess.Popen[str], float]) -> None:
    lock, holder, _ = held_lock
    result, _ = install(lock, 1)
    assert result.returncode == 100
    assert f"install.sh: {lock} still held by PID {holder.pid}" in result.stderr
    assert "giving up" in result.stderr and "apt-get" not in result.stderr


LONG_STEPS = (
    "apt-get -o DPkg::Lock::Timeout=600 install",
    "pip install -q -c constraints.txt",
    "build_ros2_interfaces",
    "pip install -q -e .",
)


def test_every_long_step_is_announced(tmp_path: Path) -> None:
    """Each step that runs quiet for minutes (apt-get install, pip's installs, the ROS 2 interfaces' compilation)
    follows a stage line naming it, with the time since the start; the last line says it is done. Seeded fault: the
    `stage` call before build_ros2_interfaces.sh removed, the last step follows pip's line, and this fails."""
    lock = tmp_path / "lock-frontend"
    lock.touch()
    result, _ = install(lock, 600, "test")
    assert result.returncode == 0, result.stderr
    lines = result.stderr.splitlines()
    stages = [i for i, line in enumerate(lines) if re.fullmatch(r"install\.sh: \[\d+:\d\d\] \S.*", line)]
    long_steps = [i for i, line in enumerate(lines) if any(step in line for step in LONG_STEPS)]
    assert len(long_steps) == 6, lines
    for step in long_steps:
        announced = max((i for i in stages if i < step), default=-1)
        since = [line for line in lines[announced + 1 : step] if any(s in line for s in LONG_STEPS)]
        assert announced >= 0 and not since, f"{lines[step]} is not announced"
    assert lines[-1].endswith("] done")
