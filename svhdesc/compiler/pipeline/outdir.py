"""The output directory: one build at a time, and each variant swapped in whole.

At every instant ``OUT/<variant>`` is the complete old or the complete new output, even if the
build is killed (SIGKILL included): a new variant directory is staged in ``OUT/.svhdesc-build-*``
and exchanged with the old one by one ``renameat2(RENAME_EXCHANGE)``, an atomic kernel operation
(Linux >= 3.15, ext4/xfs/btrfs/tmpfs). Where the filesystem cannot exchange (some network and FUSE
filesystems), no two renames can keep that promise, so a build that would replace an existing
variant there is refused before it writes anything, naming the filesystem; a variant that is new to
``OUT`` is still renamed into place, which is atomic everywhere. Variant directories stay plain
directories, so git, ``pip wheel`` and ``build --check`` see ordinary files.

Builds into one ``OUT`` serialise on an ``flock`` of the directory itself (no lock file in it);
the next build under the lock removes whatever a killed one left in staging.
"""

from __future__ import annotations

import ctypes
import errno
import fcntl
import os
import shutil
import sys
import tempfile
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

from svhdesc.core import manifest as manifest_file
from svhdesc.errors import SvhdescError

STAGING_PREFIX = ".svhdesc-build-"
RETIRED_PREFIX = ".old-"
AT_FDCWD = -100
RENAME_EXCHANGE = 2
# Test hook: after the first variant has been swapped in, pause until this file exists (60 s at most),
# so that a test can kill the build there, or hold its lock.
PAUSE_ENV = "SVHDESC_TEST_PAUSE_IN_SWAP"
# Test hook: behave as on a filesystem without RENAME_EXCHANGE.
NO_EXCHANGE_ENV = "SVHDESC_TEST_NO_EXCHANGE"


def fs_error(path: Path, exc: OSError) -> SvhdescError:
    """One line for a filesystem failure, naming the path; a file being staged is named by where it goes
    (``OUT/svh_right/...``, not ``OUT/.svhdesc-build-x1y2/svh_right/...``)."""
    reason = exc.strerror or str(exc)
    if exc.errno == errno.ENOSPC:
        reason = "no space left on the device"
    return SvhdescError(f"{_published_name(exc.filename) if exc.filename else path}: {reason}")


def _published_name(filename: object) -> str:
    parts = Path(os.fsdecode(filename)).parts  # type: ignore[arg-type]
    staged = next((i for i, part in enumerate(parts) if part.startswith(STAGING_PREFIX)), None)
    return str(Path(*parts[:staged], *parts[staged + 1 :])) if staged is not None else str(Path(*parts))


def _exchange(a: Path, b: Path) -> bool:
    """Atomically swap two paths; False if the kernel or filesystem cannot."""
    if not sys.platform.startswith("linux") or os.environ.get(NO_EXCHANGE_ENV):
        return False
    libc = ctypes.CDLL(None, use_errno=True)
    renameat2 = getattr(libc, "renameat2", None)
    if renameat2 is None:
        return False
    result = renameat2(AT_FDCWD, os.fsencode(a), AT_FDCWD, os.fsencode(b), RENAME_EXCHANGE)
    if result == 0:
        return True
    code = ctypes.get_errno()
    if code in (errno.ENOSYS, errno.EINVAL, errno.ENOTSUP):
        return False
    raise OSError(code, os.strerror(code), str(b))


def swap_in(new: Path, target: Path) -> None:
    """Make ``new`` the content of ``target``; the old content ends up at ``new`` (to delete)."""
    if not target.exists():
        os.rename(new, target)
        return
    if not _exchange(new, target):  # require_exchange() refused such a build before it began
        raise SvhdescError(f"{target}: {filesystem(target)} cannot exchange directories atomically")


def filesystem(path: Path) -> str:
    """The type of the filesystem holding ``path`` ("filesystem 'nfs4' at /mnt"), from /proc/self/mountinfo."""
    best, kind = "", "unknown"
    try:
        lines = Path("/proc/self/mountinfo").read_text().splitlines()
    except OSError:
        lines = []
    resolved = str(path.resolve())
    for line in lines:
        fields = line.split()
        if " - " not in line or len(fields) < 5:
            continue
        mount = fields[4].replace("\\040", " ")
        inside = resolved == mount or resolved.startswith(mount.rstrip("/") + "/")
        if inside and len(mount) >= len(best):
            best, kind = mount, line.split(" - ", 1)[1].split()[0]
    return f"filesystem {kind!r} at {best or '/'}"


def refuse_foreign(out: Path, names: list[str]) -> None:
    """Refuse, before anything is written, to replace ``OUT/<variant>`` where svhdesc did not write it: a file, a
    link, a folder without a manifest.json, or one whose manifest names another variant is the user's, never deleted.
    A manifest that is there but damaged is svhdesc's own folder, rebuilt as before."""
    for name in names:
        target = out / name
        if not os.path.lexists(target):
            continue
        if target.is_symlink() or not target.is_dir():
            what = "a link" if target.is_symlink() else "a file"
        elif not os.path.lexists(manifest_file.path(target)):
            what = "a folder without a manifest.json"
        elif (found := manifest_file.read(target)) is not None and found.get("variant") not in (None, name):
            what = f"the build of variant {found.get('variant')!r}"
        else:
            continue
        raise SvhdescError(
            f"{target}: {what}, not a build of {name} by svhdesc: refusing to replace it (move it away, or build "
            "into another --out)"
        )


def require_exchange(staging: Path, out: Path, names: list[str]) -> None:
    """Refuse, before anything is written, a build that would replace a variant where directories cannot be
    exchanged atomically: two renames leave ``OUT/<variant>`` missing between them."""
    replaced = [name for name in names if (out / name).exists()]
    if not replaced:
        return
    a, b = staging / ".probe-a", staging / ".probe-b"
    a.mkdir()
    b.mkdir()
    try:
        if _exchange(a, b):
            return
    finally:
        shutil.rmtree(a, ignore_errors=True)
        shutil.rmtree(b, ignore_errors=True)
    raise SvhdescError(
        f"{out}: the {filesystem(out)} cannot exchange directories atomically (renameat2 RENAME_EXCHANGE), so "
        f"{replaced[0]} cannot be replaced crash-safely there; build into a new --out, or remove {out / replaced[0]}"
    )


def recover(out: Path) -> None:
    """Undo what a killed build left: put back a variant an older release's two-rename swap moved aside, delete
    staging directories."""
    for staging in sorted(out.glob(f"{STAGING_PREFIX}*")):
        for retired in staging.glob(f"{RETIRED_PREFIX}*"):
            target = out / retired.name.removeprefix(RETIRED_PREFIX)
            if not target.exists():
                os.rename(retired, target)
        shutil.rmtree(staging, ignore_errors=True)


def tidy(out: Path) -> None:
    """Remove what a killed build left in ``out`` (under the lock), also when nothing is to be built."""
    if out.is_dir() and any(out.glob(f"{STAGING_PREFIX}*")):
        with locked(out):
            recover(out)


@contextmanager
def locked(out: Path) -> Iterator[None]:
    """Hold ``out`` for one build; a second build into it waits (and says so)."""
    fd = os.open(out, os.O_RDONLY | os.O_DIRECTORY)
    try:
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            print(f"waiting for another build writing {out}", file=sys.stderr, flush=True)
            fcntl.flock(fd, fcntl.LOCK_EX)
        yield
    finally:
        os.close(fd)


@contextmanager
def output_directory(out: Path) -> Iterator[Path]:
    """``out`` created if needed and locked, leftovers recovered; yields a fresh staging directory.

    If the build fails, the staging directory goes, and so does ``out`` if this build created it
    and nothing else is in it.
    """
    if out.exists() and not out.is_dir():
        raise SvhdescError(f"{out}: --out is not a directory")
    # The directories this build creates (out and missing parents), removed again if it fails.
    created = [d for d in (out, *out.parents) if not d.exists()]
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise fs_error(out, exc) from None
    staging = None
    try:
        with locked(out):
            recover(out)
            staging = Path(tempfile.mkdtemp(prefix=STAGING_PREFIX, dir=out))
            yield staging
    except OSError as exc:
        raise fs_error(out, exc) from None
    finally:
        if staging is not None:
            shutil.rmtree(staging, ignore_errors=True)
        for directory in created:
            try:
                directory.rmdir()  # only if empty: the build failed before swapping anything in
            except OSError:
                break


def publish(staging: Path, out: Path, names: list[str]) -> None:
    """Swap each staged variant into ``out``."""
    for index, name in enumerate(names):
        swap_in(staging / name, out / name)
        if index == 0 and os.environ.get(PAUSE_ENV):
            print(f"swapped {name}; pausing", file=sys.stderr, flush=True)
            release, deadline = Path(os.environ[PAUSE_ENV]), time.monotonic() + 60
            while not release.exists() and time.monotonic() < deadline:
                time.sleep(0.05)
