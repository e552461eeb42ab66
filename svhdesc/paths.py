"""Where the configuration, the sources and the generated models live: in a checkout or in an installed wheel.

A checkout is found from the working directory first, so that `svhdesc build` inside a checkout builds that checkout
whichever checkout (or wheel) the interpreter imported svhdesc from. A wheel ships the sources under
``svhdesc/source`` (read-only) and the built models under ``svhdesc/generated``.
"""

from __future__ import annotations

import os
from pathlib import Path

from svhdesc.errors import SvhdescError

PACKAGE_DIR = Path(__file__).resolve().parent
SHIPPED_SOURCE = PACKAGE_DIR / "source"
SHIPPED_MODELS = PACKAGE_DIR / "generated"
CONFIG_NAME = Path("config") / "svhdesc.yaml"


def user_cache(name: str) -> Path:
    """``$XDG_CACHE_HOME/svhdesc/NAME`` (``~/.cache`` where the variable is unset or empty, as the XDG spec says)."""
    return Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache") / "svhdesc" / name


def is_checkout(directory: Path) -> bool:
    return (
        (directory / "pyproject.toml").is_file()
        and (directory / CONFIG_NAME).is_file()
        and (directory / "svhdesc" / "__init__.py").is_file()
    )


def checkout_root(start: Path | None = None) -> Path | None:
    """The svhdesc checkout holding ``start`` (default: the working directory), else the one svhdesc runs from."""
    here = (start or Path.cwd()).resolve()
    for directory in (here, *here.parents):
        if is_checkout(directory):
            return directory
    return PACKAGE_DIR.parent if is_checkout(PACKAGE_DIR.parent) else None


def source_root() -> Path:
    """Where config/, xacro/ and meshes/ are: the checkout, else the copy inside the wheel."""
    return checkout_root() or SHIPPED_SOURCE


def default_config() -> Path:
    return source_root() / CONFIG_NAME


def generated_dir() -> Path:
    """The models this svhdesc was installed with (the API's view): inside the wheel, else its checkout's."""
    return SHIPPED_MODELS if SHIPPED_MODELS.is_dir() else PACKAGE_DIR.parent / "generated"


def models_dir() -> Path:
    """The models the CLI reads by default: the working checkout's generated/, else the installed ones."""
    root = checkout_root()
    return root / "generated" if root else generated_dir()


def default_out(config_path: Path | None) -> Path:
    """Beside the config: <checkout>/generated for a checkout's own config, else <config's folder>/generated.

    Never inside an installed package: the shipped sources are read-only data.
    """
    config = (config_path or default_config()).resolve()
    root = config.parent.parent
    out = root / "generated" if config == (root / CONFIG_NAME) and is_checkout(root) else config.parent / "generated"
    if out.is_relative_to(PACKAGE_DIR) and not is_checkout(PACKAGE_DIR.parent):
        raise SvhdescError(
            f"{config} is the configuration shipped inside the installed package; "
            "give --out DIR (or run inside a checkout, or pass --config FILE of your own)"
        )
    return out
