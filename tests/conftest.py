"""Session-wide test settings."""

import os
from pathlib import Path

# MuJoCo Warp compiles its kernels once into the repo's ignored .cache/ (inherited by CLI subprocesses too).
os.environ.setdefault("WARP_CACHE_PATH", str(Path(__file__).resolve().parents[1] / ".cache" / "warp"))
