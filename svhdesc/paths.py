"""Where the configuration and the generated models live, in a checkout and in an installed wheel."""

from __future__ import annotations

from pathlib import Path

PACKAGE_DIR = Path(__file__).resolve().parent
REPO_DIR = PACKAGE_DIR.parent
DEFAULT_CONFIG = REPO_DIR / "config" / "svhdesc.yaml"


def generated_dir() -> Path:
    """Models shipped inside the wheel, else the checkout's generated/."""
    shipped = PACKAGE_DIR / "generated"
    return shipped if shipped.is_dir() else REPO_DIR / "generated"


def default_out() -> Path:
    return REPO_DIR / "generated"
