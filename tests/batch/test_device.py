"""svhdesc.batch.device: Warp starts without its chatter, and a device the machine lacks is one clear error.

Seeded faults: the CUDA check in ``warp_device`` removed (Warp's get_device raises its own RuntimeError and writes
native "Warp CUDA error" lines: the first test fails on a machine without a GPU); the notice filter in
``quiet_init`` removed (the second and third fail); ``wp.config.quiet`` left unset (the banner and the
``Module ... load`` line reach the output: the third fails).
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path
from types import SimpleNamespace

import pytest

from svhdesc.batch.device import DRIVER_NOTICE, quiet_init
from svhdesc.errors import SvhdescError
from tests.support import REPO

wp = pytest.importorskip("warp")
pytest.importorskip("mujoco_warp")
WARP_CACHE = {"WARP_CACHE_PATH": os.environ.get("WARP_CACHE_PATH", str(REPO / ".cache" / "warp"))}


@pytest.mark.skipif(wp.is_cuda_available(), reason="this machine has a CUDA GPU")
def test_cuda_without_a_gpu_is_one_clear_error() -> None:
    from svhdesc.batch import make

    with pytest.raises(SvhdescError, match=r"device 'cuda': no CUDA GPU on this machine .* use device 'cpu'"):
        make("svh_right", nworld=2, device="cuda")


def test_the_driver_notice_is_dropped_and_other_lines_pass(capfd: pytest.CaptureFixture[str]) -> None:
    """What Warp's native start writes to file descriptor 2 (a stand-in for it that writes there): the CUDA-driver
    notice goes, anything else stays."""

    def init() -> None:
        os.write(2, f"Warp CUDA warning: {DRIVER_NOTICE}. GPU execution will not be available.\n".encode())
        os.write(2, b"Warp error: something else\n")

    quiet_init(SimpleNamespace(config=SimpleNamespace(), init=init, LOG_ERROR=3))
    assert capfd.readouterr().err == "Warp error: something else\n"


KERNEL = """
import warp as wp
from svhdesc.batch.device import warp_device

device = warp_device(wp, "cpu")

@wp.kernel
def fill(a: wp.array(dtype=float)):
    a[wp.tid()] = 1.0

values = wp.zeros(4, dtype=float, device=device)
wp.launch(fill, dim=4, inputs=[values], device=device)
print(values.numpy().sum())
"""


def test_warp_starts_and_loads_a_module_without_a_word(tmp_path: Path) -> None:
    script = tmp_path / "kernel.py"  # Warp reads a kernel's source from its file
    script.write_text(KERNEL)
    result = subprocess.run(
        [sys.executable, str(script)],
        capture_output=True,
        text=True,
        cwd=REPO,
        env={**os.environ, **WARP_CACHE, "PYTHONPATH": str(REPO)},
        timeout=300,
    )
    assert result.returncode == 0, result.stderr
    assert (result.stdout, result.stderr) == ("4.0\n", "")
