"""Build variants into an output directory: atomic, deterministic, with a manifest; or --check it."""

from __future__ import annotations

import filecmp
import hashlib
import json
import os
import shutil
import tempfile
from importlib import metadata
from pathlib import Path

from .config import Config, Variant
from .export.mjcf import export_mjcf, export_scene
from .export.urdf import export_urdf
from .pipeline import compile_variant

TOOLS = ("svhdesc", "xacro", "lxml", "numpy", "trimesh", "pycollada", "scipy", "coacd")


def _version(tool: str) -> str:
    try:
        return metadata.version(tool)
    except metadata.PackageNotFoundError:
        return "absent"


def _portable(path: Path, packages: dict[str, Path], config_dir: Path) -> str:
    """Name an input independently of where the checkout lives: package://PKG/... if possible."""
    for name, root in sorted(packages.items(), key=lambda item: -len(str(item[1]))):
        if path.is_relative_to(root):
            return f"package://{name}/{path.relative_to(root).as_posix()}"
    return os.path.relpath(path, config_dir)


def _sha256(data: bytes) -> str:
    return hashlib.sha256(data).hexdigest()


def write_variant(variant: Variant, directory: Path, extra_packages: dict[str, Path], config_path: Path) -> None:
    compiled = compile_variant(variant, extra_packages)
    robot = compiled.robot
    directory.mkdir(parents=True)
    (directory / "assets").mkdir()
    for name, data in sorted(compiled.assets.files.items()):
        (directory / "assets" / name).write_bytes(data)
    outputs = {
        f"{variant.name}.urdf": export_urdf(robot),
        f"{variant.name}.xml": export_mjcf(robot, variant.settings),
        "scene.xml": export_scene(robot, f"{variant.name}.xml", variant.settings["scene"]),
    }
    for name, data in outputs.items():
        (directory / name).write_bytes(data)
    packages = {**variant.packages(), **extra_packages}
    inputs = {
        _portable(p, packages, variant.config_dir): _sha256(p.read_bytes())
        for p in sorted(set(compiled.inputs) | {config_path.resolve()})
    }
    produced = {
        path.relative_to(directory).as_posix(): _sha256(path.read_bytes())
        for path in sorted(directory.rglob("*"))
        if path.is_file()
    }
    manifest = {
        "variant": variant.name,
        "inputs": inputs,
        "outputs": produced,
        "tools": {tool: _version(tool) for tool in TOOLS},
    }
    (directory / "manifest.json").write_text(json.dumps(manifest, indent=2, sort_keys=True) + "\n")


def build(config: Config, names: list[str], out: Path, extra_packages: dict[str, Path]) -> list[str]:
    """Build into a temporary directory beside ``out``, then swap each variant in; returns variant names."""
    variants = config.select(names)
    out.mkdir(parents=True, exist_ok=True)
    staging = Path(tempfile.mkdtemp(prefix=".svhdesc-build-", dir=out))
    try:
        for variant in variants:
            write_variant(variant, staging / variant.name, extra_packages, config.path)
        for variant in variants:
            target, retired = out / variant.name, staging / f".old-{variant.name}"
            if target.exists():
                os.replace(target, retired)
            os.replace(staging / variant.name, target)
    finally:
        shutil.rmtree(staging, ignore_errors=True)
    return [v.name for v in variants]


def check(config: Config, names: list[str], out: Path, extra_packages: dict[str, Path]) -> list[str]:
    """Build into a temporary directory and list every file that differs from ``out``."""
    variants = config.select(names)
    with tempfile.TemporaryDirectory(prefix="svhdesc-check-") as tmp:
        fresh = Path(tmp)
        for variant in variants:
            write_variant(variant, fresh / variant.name, extra_packages, config.path)
        differences = []
        for variant in variants:
            new, old = fresh / variant.name, out / variant.name
            new_files = {p.relative_to(new) for p in new.rglob("*") if p.is_file()}
            old_files = {p.relative_to(old) for p in old.rglob("*") if p.is_file()} if old.is_dir() else set()
            for rel in sorted(new_files | old_files):
                if rel not in old_files:
                    differences.append(f"{variant.name}/{rel} (missing)")
                elif rel not in new_files:
                    differences.append(f"{variant.name}/{rel} (stale: the build no longer makes it)")
                elif not filecmp.cmp(new / rel, old / rel, shallow=False):
                    differences.append(f"{variant.name}/{rel} (differs)")
    return differences
