"""One variant from source to IR: expand, read, couple, then the processors in order."""

from __future__ import annotations

import warnings
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np
from lxml import etree

from svhdesc.compiler.build.timings import Timings
from svhdesc.compiler.decompose.source import HullSource
from svhdesc.compiler.export.urdf import mimic_order_problems
from svhdesc.compiler.settings.config import Variant
from svhdesc.compiler.settings.coupling import couple
from svhdesc.compiler.source.packages import resolve_uri
from svhdesc.compiler.source.urdf import read_urdf
from svhdesc.compiler.source.xacro import expand_xacro
from svhdesc.compiler.stages.actuation import add_actuation, add_force_sensor, add_keyframes
from svhdesc.compiler.stages.assets import Assets
from svhdesc.compiler.stages.collision_rules import collision_rules
from svhdesc.compiler.stages.collisions import add_excludes
from svhdesc.compiler.stages.contact import add_contact
from svhdesc.compiler.stages.geometry import bake_meshes, decomposition_jobs
from svhdesc.compiler.stages.inertials import add_inertials, link_solid
from svhdesc.compiler.stages.rest_contacts import touching_at_rest
from svhdesc.compiler.stages.semantics import check_driven, check_hand_names, check_keyframes, check_unique_names
from svhdesc.compiler.stages.world import add_world
from svhdesc.ir import Robot


@dataclass
class Compiled:
    robot: Robot
    assets: Assets
    inputs: list[Path]  # every file the build read, for the manifest


@dataclass
class Source:
    robot: Robot  # as read: kinematics and geometry, nothing injected yet
    inputs: list[Path]


def read_source(variant: Variant, extra_packages: dict[str, Path], timings: Timings) -> Source:
    packages = {**variant.packages(), **extra_packages}
    with timings.stage("xacro"):
        tree, inputs = expand_xacro(variant.xacro, variant.args, packages)
    with timings.stage("read"):
        robot = replace(read_urdf(tree, packages, variant.xacro, inputs), name=variant.name)
    return Source(robot, [*inputs, *_mesh_sources(tree, packages, variant.xacro)])


def decomposition_plan(variant: Variant, source: Source) -> list:
    """The decompositions this variant needs, so a build can run them all in parallel first."""
    rules = collision_rules(source.robot, variant.settings["collision"], variant.hand["prefix"])
    return decomposition_jobs(source.robot, rules)


def compile_variant(
    variant: Variant,
    extra_packages: dict[str, Path],
    hulls: HullSource | None = None,
    timings: Timings | None = None,
    source: Source | None = None,
) -> Compiled:
    timings = timings or Timings()
    sections = variant.sections  # typed, checked settings: each stage gets its own section
    source = source or read_source(variant, extra_packages, timings)
    spec_path = variant.path("coupling") if sections.coupling else None  # no spec: a robot without couplings
    prefix = sections.hand.prefix
    with timings.stage("coupling"):
        widen = sections.coupled_limits == "widen"
        robot = couple(source.robot, spec_path, prefix, widen_limits=widen)
        for problem in mimic_order_problems(robot):
            # A warning, not an error: the URDF is valid, only pinocchio's mimic=True cannot load it.
            warnings.warn(f"{problem}: pinocchio cannot build its mimic model (rename a sibling joint)", stacklevel=2)
    assets = Assets()
    with timings.stage("meshes"):
        rules = collision_rules(robot, variant.settings["collision"], prefix)
        robot = bake_meshes(robot, assets, rules, hulls)
    with timings.stage("inertials"):
        robot = add_inertials(robot, assets, sections.mass, prefix)
    with timings.stage("physics"):
        robot = add_contact(robot, sections.contact, sections.hand)
        robot = add_actuation(robot, sections.hand, sections.arm, sections.transmissions)
        robot = add_keyframes(robot, variant.settings["keyframes"], set(sections.arm.joints))
        check_hand_names(robot, sections.hand)
        check_driven(robot)
        check_keyframes(robot, variant.settings["keyframes"], _at(variant))
        bounds = {link.name: np.array(link_solid(link, assets).bounds) for link in robot.links if link.collisions}
        robot = add_force_sensor(robot, sections.hand, bounds)
        check_unique_names(robot, sections.hand, sections.arm)
        robot = add_world(robot, sections.simulation, sections.scene)
    with timings.stage("exclusions"):
        robot = add_excludes(robot, lambda r: touching_at_rest(r, assets))
    return Compiled(robot, assets, [*source.inputs, *([spec_path] if spec_path else [])])


def _at(variant: Variant) -> str:
    return getattr(variant.settings, "where", "") or str(variant.config_dir)


def _mesh_sources(tree: etree._Element, packages: dict[str, Path], source: Path) -> list[Path]:
    paths = []
    for mesh in tree.iter("mesh"):
        path = resolve_uri(mesh.get("filename", ""), packages, str(source))
        paths.append((path if path.is_absolute() else source.parent / path).resolve())
    return sorted(set(paths))
