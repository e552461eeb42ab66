"""Is a built variant current? Its manifest names every input, output and tool by content hash.

Cheap on purpose (hashing, no mesh or XML library): a warm build or --check of unchanged sources
needs only this. Anything that differs (a source, an output, a tool version, svhdesc's own code)
sends the variant through the full build.
"""

from __future__ import annotations

import hashlib
import os
from functools import cache
from importlib import metadata
from pathlib import Path

from svhdesc.core import manifest as manifest_file
from svhdesc.core.settings.config import Variant

TOOLS = (
    "svhdesc",
    "xacro",
    "lxml",
    "numpy",
    "trimesh",
    "pycollada",
    "scipy",
    "coacd",
    "manifold3d",
    "mujoco",
    "usd-core",
)
PACKAGE_DIR = Path(__file__).resolve().parents[2]  # svhdesc/


def sha256(data: bytes) -> str:
    return hashlib.sha256(data).hexdigest()


@cache
def code_fingerprint() -> str:
    """Hash of svhdesc's own source: a code change must rebuild even at the same version number.

    The compiler wing and the shared modules it imports count; code that reads models and does not make them (the
    validator, the runtime wing, the CLI and the import API) is left out: changing it must not change the models'
    manifests.
    """
    return fingerprint_of(PACKAGE_DIR)


def fingerprint_of(package: Path) -> str:
    digest = hashlib.sha256()
    for path in sorted(p for p in package.rglob("*.py") if makes_models(p.relative_to(package))):
        digest.update(path.relative_to(package).as_posix().encode() + b"\0" + path.read_bytes())
    return digest.hexdigest()


RUNTIME = {"validate", "loaders", "sim", "ros1", "ros2", "control", "plan", "compare", "wireloop", "batch"}
FRONT = {"cli.py", "__init__.py", "extras.py", "paths.py", "offscreen.py"}
# An installed wheel ships the models and their sources inside the package; the models' Python files (the ROS 2
# launch files) are outputs, not code.
SHIPPED = {"generated", "source"}


def makes_models(relative: Path) -> bool:
    return relative.parts[0] not in RUNTIME | FRONT | SHIPPED


def svhdesc_version() -> str:
    try:
        return metadata.version("svhdesc")
    except metadata.PackageNotFoundError:
        return "0.0.0"


def tool_versions() -> dict[str, str]:
    versions = {}
    for tool in TOOLS:
        try:
            versions[tool] = metadata.version(tool)
        except metadata.PackageNotFoundError:
            versions[tool] = "absent"
    versions["svhdesc-code"] = code_fingerprint()
    return versions


def portable(path: Path, packages: dict[str, Path], config_dir: Path) -> str:
    """Name an input independently of where the checkout lives: package://PKG/... if possible."""
    for name, root in sorted(packages.items(), key=lambda item: -len(str(item[1]))):
        if path.is_relative_to(root):
            return f"package://{name}/{path.relative_to(root).as_posix()}"
    return os.path.relpath(path, config_dir)


def resolve_portable(name: str, packages: dict[str, Path], config_dir: Path) -> Path | None:
    if name.startswith("package://"):
        package, _, rest = name[len("package://") :].partition("/")
        return packages[package] / rest if package in packages else None
    return config_dir / name


def up_to_date(variant: Variant, directory: Path, packages: dict[str, Path]) -> bool:
    manifest = manifest_file.read(directory)
    if manifest is None or manifest.get("variant") != variant.name:
        return False
    if manifest.get("tools") != tool_versions():
        return False
    for name, digest in manifest.get("inputs", {}).items():
        path = resolve_portable(name, packages, variant.config_dir)
        if path is None or not path.is_file() or sha256(path.read_bytes()) != digest:
            return False
    outputs = manifest.get("outputs", {})
    present = {p.relative_to(directory).as_posix() for p in directory.rglob("*") if p.is_file()}
    if present != set(outputs) | {manifest_file.FILE}:
        return False
    return all(sha256((directory / rel).read_bytes()) == digest for rel, digest in outputs.items())


def stale_variants(variants: list[Variant], out: Path, extra_packages: dict[str, Path]) -> list[Variant]:
    return [v for v in variants if not up_to_date(v, out / v.name, {**v.packages(), **extra_packages})]
