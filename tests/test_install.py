"""tools/install.sh waits for apt's locks (held by unattended-upgrades on a fresh VM) instead of failing with 100.

The real script runs in its dry-run mode (every step but the commands themselves) against a lock file of the
test's own, held the way apt and dpkg hold theirs: an fcntl write lock.
"""

from __future__ import annotations

import os
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
    assert lines[2] == "+ apt-get -o DPkg::Lock::Timeout=600 update -qq"
    assert lines[3].startswith("+ apt-get -o DPkg::Lock::Timeout=600 install -y -qq --no-install-recommends python3 ")
    assert lines[-1] == "+ .venv/bin/python -m pip install -q -c constraints.txt -e .[build]"


def test_a_free_lock_is_not_waited_for(tmp_path: Path) -> None:
    lock = tmp_path / "lock-frontend"
    lock.touch()
    result, _ = install(lock, 600, "test")
    assert result.returncode == 0, result.stderr
    assert "waiting" not in result.stderr
    assert result.stderr.startswith("+ apt-get -o DPkg::Lock::Timeout=600 update -qq\n")
    assert "liburdfdom-tools" in result.stderr and "-e .[test]" in result.stderr


def test_gives_up_after_its_wait_naming_the_holder(held_lock: tuple[Path, subprocess.Popen[str], float]) -> None:
    lock, holder, _ = held_lock
    result, _ = install(lock, 1)
    assert result.returncode == 100
    assert f"install.sh: {lock} still held by PID {holder.pid}" in result.stderr
    assert "giving up" in result.stderr and "apt-get" not in result.stderr
