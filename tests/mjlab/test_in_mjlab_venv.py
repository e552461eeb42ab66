"""The mjlab tests (test_entity.py, test_train.py) import mjlab, which pins MuJoCo 3.11: they skip in `.venv` and
run here in the mjlab venv's Python (``.venv-mjlab/bin/python`` of this checkout, or $SVHDESC_MJLAB_PYTHON), where
they must pass without a skip (seeded: test_entity.py's dropped coupling fails its comparison, and so this).
MuJoCo Warp's CPU kernels for 3.11 go to the suite's Warp cache (tests/conftest.py): a fresh cache adds their
compilation (about 90 s of one CPU) to this test's time."""

from __future__ import annotations

import importlib.util
import os
from pathlib import Path

import pytest

from tests.support import pytest_in_venv

ROOT = Path(__file__).resolve().parents[2]
PYTHON = Path(os.environ.get("SVHDESC_MJLAB_PYTHON", ROOT / ".venv-mjlab" / "bin" / "python"))
IN_MJLAB_VENV = ("test_entity.py", "test_train.py")

pytestmark = pytest.mark.slow  # one pytest session in the other venv: a minute and more


@pytest.mark.skipif(importlib.util.find_spec("mjlab") is not None, reason="mjlab is here: those tests run directly")
@pytest.mark.skipif(not PYTHON.is_file(), reason=f"no mjlab Python at {PYTHON} (bash tools/install.sh test)")
def test_the_mjlab_venv_tests_pass_there(tmp_path: Path) -> None:
    files = [str(Path(__file__).with_name(name)) for name in IN_MJLAB_VENV]
    pytest_in_venv(PYTHON, files, tmp_path, {"MJLAB_WARP_QUIET": "1"})
