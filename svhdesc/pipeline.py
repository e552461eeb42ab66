"""One variant from source to IR: expand, read, couple, then the processors in order."""

from __future__ import annotations

from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np
from lxml import etree

from .config import Variant
from .coupling import apply_spec, load_spec
from .ir import Robot
from .packages import resolve_uri
from .stages.actuation import add_actuation, add_force_sensor, add_keyframes
from .stages.assets import Assets
from .stages.collisions import add_excludes
from .stages.contact import add_contact
from .stages.geometry import bake_meshes
from .stages.inertials import add_inertials, link_solid
from .urdf_reader import read_urdf
from .xacro_expand import expand_xacro


@dataclass
class Compiled:
    robot: Robot
    assets: Assets
    inputs: list[Path]  # every file the build read, for the manifest


def compile_variant(variant: Variant, extra_packages: dict[str, Path]) -> Compiled:
    packages = {**variant.packages(), **extra_packages}
    tree, inputs = expand_xacro(variant.xacro, variant.args, packages)
    robot = read_urdf(tree, packages, variant.xacro)
    robot = replace(robot, name=variant.name)
    spec_path = variant.path("coupling")
    spec = load_spec(spec_path)
    prefix = variant.hand["prefix"]
    robot = apply_spec(robot, spec, prefix, widen_limits=variant.settings["coupled_limits"] == "widen")
    assets = Assets()
    robot = bake_meshes(robot, assets)
    robot = add_inertials(robot, assets, variant.settings["mass"], prefix)
    robot = add_contact(robot, variant.settings["contact"], variant.hand)
    robot = add_actuation(robot, variant.settings)
    robot = add_keyframes(robot, variant.settings["keyframes"], prefix, set(variant.arm.get("joints", [])))
    bounds = {link.name: np.array(link_solid(link, assets).bounds) for link in robot.links if link.collisions}
    robot = add_force_sensor(robot, variant.hand, bounds)
    robot = add_excludes(robot, assets, variant.settings)
    return Compiled(robot, assets, [*inputs, spec_path, *_mesh_sources(tree, packages, variant.xacro)])


def _mesh_sources(tree: etree._Element, packages: dict[str, Path], source: Path) -> list[Path]:
    paths = []
    for mesh in tree.iter("mesh"):
        path = resolve_uri(mesh.get("filename", ""), packages, str(source))
        paths.append((path if path.is_absolute() else source.parent / path).resolve())
    return sorted(set(paths))
