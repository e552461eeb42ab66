"""Warp, started quietly, and the device a batch runs on: a clear error where there is no such device.

Warp prints a banner, one ``Module ... load`` line per kernel module and, on a machine without a GPU, a CUDA-driver
notice from its native library (straight to file descriptor 2, past Python's streams). None of it is the
caller's output: the first two are switched off in Warp's config, the notice is taken out of what Warp's start
writes (anything else it writes is passed on).
"""

from __future__ import annotations

import os
import sys
import tempfile
from typing import Any

from svhdesc.errors import SvhdescError

DRIVER_NOTICE = "Could not find or load the NVIDIA CUDA driver"


def quiet_init(wp: Any) -> None:
    """Start Warp (once) without its banner, module-load lines or CUDA-driver notice; its errors still show."""
    wp.config.quiet = True
    if hasattr(wp, "LOG_ERROR"):  # warp >= 1.19 has a log level; older ones the quiet flag only
        wp.config.log_level = wp.LOG_ERROR
    sys.stderr.flush()
    saved = os.dup(2)
    with tempfile.TemporaryFile(mode="w+") as caught:
        os.dup2(caught.fileno(), 2)
        try:
            wp.init()
        finally:
            os.dup2(saved, 2)
            os.close(saved)
            caught.seek(0)
            sys.stderr.writelines(line for line in caught if DRIVER_NOTICE not in line)


def warp_device(wp: Any, device: str) -> Any:
    """Warp's device for ``device`` ("cpu", "cuda", "cuda:N"), or an SvhdescError saying why there is none."""
    quiet_init(wp)
    if device.startswith("cuda") and not wp.is_cuda_available():
        raise SvhdescError(f"device {device!r}: no CUDA GPU on this machine (Warp finds no driver): use device 'cpu'")
    try:
        return wp.get_device(device)
    except (RuntimeError, ValueError) as exc:
        known = ", ".join(str(d) for d in wp.get_devices())
        raise SvhdescError(f"device {device!r}: {exc} (this machine has: {known})") from None
