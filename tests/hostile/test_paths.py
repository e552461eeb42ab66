"""Paths are checked before any work, with the reason: an input of ``train --resume``, ``play --checkpoint`` or
``deploy --policy`` that is not a regular file (a FIFO, a symbolic link to one, a device, a socket, a folder, a
loop of links) is refused as what it is, not as "not found"; ``play --out`` where a folder (or anything but a
file) stands, or below a file, is refused before the policy is even read.

Seeded faults, each failing the test named: ``regular_file`` as the old ``is_file()`` test (each kind reported as
"no such checkpoint": test_inputs_that_are_not_regular_files); ``regular_file`` not called (the FIFO is opened:
a writer this test starts after 10 s ends the read, and the message is "not a checkpoint", not the FIFO's);
``_picture_path`` not called in ``run_play`` (the missing checkpoint is reported first, the folder never:
test_a_picture_where_a_folder_stands).
"""

from __future__ import annotations

import contextlib
import os
import socket
import threading
from collections.abc import Iterator
from pathlib import Path

import pytest

pytest.importorskip("torch")
pytest.importorskip("onnxruntime")

from tests.support import fails_cleanly  # noqa: E402


@contextlib.contextmanager
def rescued(fifo: Path, after: float = 10.0) -> Iterator[None]:
    """Should svhdesc open ``fifo`` (a fault), a writer opens and closes it after ``after`` s, until the block ends,
    so the read ends and the test fails on the message instead of hanging."""
    timer = threading.Timer(after, lambda: _write_until(fifo, timer.finished))
    timer.daemon = True
    timer.start()
    try:
        yield
    finally:
        timer.cancel()  # sets ``finished``: the writer stops
        timer.join()


def _write_until(fifo: Path, finished: threading.Event) -> None:
    while not finished.wait(0.05):
        with contextlib.suppress(OSError):  # ENXIO: no reader yet
            os.close(os.open(fifo, os.O_WRONLY | os.O_NONBLOCK))


def _refused_by_every_command(folder: Path, path: Path, match: str) -> None:
    cases = (
        ("checkpoint", ("train", "svh_reach", "--resume", str(path), "--backend", "mujoco", "--iterations", "1")),
        ("checkpoint", ("play", "svh_reach", "--checkpoint", str(path))),
        ("policy file", ("deploy", "svh_reach", "--policy", str(path))),
    )
    for what, args in cases:
        line = fails_cleanly(folder, *args, match=match)
        assert line.startswith(f"error: {path}: ") and what in line, line  # the file, and what it was taken for


def test_inputs_that_are_not_regular_files(tmp_path: Path) -> None:
    folder = tmp_path / "run"
    folder.mkdir()
    fifo = folder / "model_1.pt"
    os.mkfifo(fifo)
    with rescued(fifo):
        _refused_by_every_command(folder, fifo, "not a regular file but a FIFO")
        (folder / "link.pt").symlink_to(fifo)
        _refused_by_every_command(folder, folder / "link.pt", "not a regular file but a FIFO")
    _refused_by_every_command(folder, Path("/dev/null"), "not a regular file but a character device")
    _refused_by_every_command(folder, folder, "not a regular file but a folder")
    with socket.socket(socket.AF_UNIX) as server:
        server.bind(str(tmp_path / "sock.pt"))
        _refused_by_every_command(folder, tmp_path / "sock.pt", "not a regular file but a socket")
    (tmp_path / "loop.pt").symlink_to(tmp_path / "loop.pt")
    _refused_by_every_command(folder, tmp_path / "loop.pt", "Too many levels of symbolic links")
    (tmp_path / "gone.pt").symlink_to(tmp_path / "never.pt")
    _refused_by_every_command(folder, tmp_path / "gone.pt", "(a symbolic link to a missing file)")


def test_a_picture_where_a_folder_stands(tmp_path: Path) -> None:
    """The strip's path is checked first: the checkpoint named does not even exist."""
    missing = str(tmp_path / "model_1.pt")
    folder = tmp_path / "strip.png"
    folder.mkdir()
    play = ("play", "svh_reach", "--checkpoint", missing, "--episodes", "0", "--out")
    fails_cleanly(tmp_path, *play, str(folder), match=f"{folder}: is a folder, not a file the strip can be written to")
    (tmp_path / "linked.png").symlink_to(folder)
    fails_cleanly(tmp_path, *play, str(tmp_path / "linked.png"), match="is a folder, not a file the strip")
    fifo = tmp_path / "fifo.png"
    os.mkfifo(fifo)
    fails_cleanly(tmp_path, *play, str(fifo), match="is a FIFO, not a file the strip can be written to")
    (tmp_path / "notes.txt").write_text("a file\n")
    below = tmp_path / "notes.txt" / "strips" / "a.png"
    fails_cleanly(tmp_path, *play, str(below), match="notes.txt is a file, not a folder to write it in")
