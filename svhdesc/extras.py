"""Optional dependencies: which pip extra brings each module, and one clear error when it is missing.

Core (always installed): click, lxml, numpy, pyyaml -- enough to find the shipped models and read configs.
Everything heavier is an extra, so that a consumer who only wants the model files installs four small packages.
"""

from __future__ import annotations

import importlib
from types import ModuleType

from svhdesc.errors import SvhdescError

# Top-level module -> (pip distribution, extra that installs it).
EXTRA_OF: dict[str, tuple[str, str]] = {
    "xacro": ("xacro", "build"),
    "trimesh": ("trimesh", "build"),
    "networkx": ("networkx", "build"),
    "collada": ("pycollada", "build"),
    "scipy": ("scipy", "build"),
    "coacd": ("coacd", "build"),
    "manifold3d": ("manifold3d", "build"),
    "pxr": ("usd-core", "build"),
    "mujoco": ("mujoco", "sim"),
    "yourdfpy": ("yourdfpy", "validate"),
    "matplotlib": ("matplotlib", "validate"),
    "pinocchio": ("pin", "engines"),
    "pybullet": ("pybullet", "engines"),
    "dartpy": ("dartpy", "engines"),
    "pydrake": ("drake", "engines"),
    "newton": ("newton", "engines"),
    "newton_usd_schemas": ("newton-usd-schemas", "engines"),
    "warp": ("warp-lang", "batch"),
    "mujoco_warp": ("mujoco-warp", "batch"),
    "torch": ("torch", "policy"),
    "rsl_rl": ("rsl-rl-lib", "rl"),
    "tensordict": ("tensordict", "rl"),
    "onnx": ("onnx", "rl"),
    "onnxruntime": ("onnxruntime", "policy"),
    "jax": ("jax", "batch-mjx"),
    "ompl": ("ompl", "plan"),
    "ruckig": ("ruckig", "plan"),
    "mjlab": ("mjlab", "mjlab"),
}


class MissingExtra(SvhdescError):
    """An optional dependency is not installed; the message names the extra that brings it."""


# The extra each CLI command needs as a whole (a command may import several of the modules above).
COMMAND_EXTRA: dict[str, str] = {
    "train": "rl",
    "play": "rl",
    "deploy": "policy",
    "build": "build",
    "info": "build",
    "validate": "validate",
    "render": "sim",
    "sim": "sim",
    "compare": "engines",
    "plan": "plan",
    "mjlab": "mjlab",
}


def missing_message(module: str, purpose: str = "", extra: str | None = None) -> str:
    top = module.split(".")[0]
    dist, own_extra = EXTRA_OF.get(top, (top, ""))
    extra = extra or own_extra
    what = f"{purpose} needs" if purpose else "needs"
    hint = f"pip install 'svhdesc[{extra}]'" if extra else f"pip install {dist}"
    return f"{what} the Python package '{dist}', which is not installed: {hint}"


def is_optional(exc: ModuleNotFoundError) -> bool:
    return (exc.name or "").split(".")[0] in EXTRA_OF


def require(module: str, purpose: str = "", extra: str | None = None) -> ModuleType:
    """Import ``module`` or raise MissingExtra naming the pip extra to install."""
    try:
        return importlib.import_module(module)
    except ModuleNotFoundError as exc:
        if exc.name and exc.name.split(".")[0] != module.split(".")[0]:
            raise  # the module exists but one of its own imports is broken: not ours to rename
        raise MissingExtra(missing_message(module, purpose, extra)) from None


def require_extra(extra: str, purpose: str) -> None:
    """Import every module ``extra`` brings, before a command touches anything (no half-made output)."""
    for module, (_, owner) in EXTRA_OF.items():
        if owner == extra or (extra == "build" and module == "mujoco"):
            require(module, purpose, extra)
