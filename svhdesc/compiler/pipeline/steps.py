"""The pipeline owner: a variant from its sources to the checked IR, in one order.

``plan_variant`` reads a variant once (xacro, URDF, coupling spec) and decides its collision rules and the
decompositions they need; ``compile_variant`` runs the processors on it in order, then the checks,
then the processors that simulate the model (they need a checked one). ``compile_variants`` does both
for the variants of a build, with every decomposition of every variant run at once in between.

A processor is ``process(robot, assets, section) -> robot``: ``section`` is what it reads, its typed
settings section(s) or the plan's own (rules, spec), picked by the processor's entry below; no stage
reads the config itself.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

from lxml import etree

from svhdesc.compiler.assets import Assets
from svhdesc.compiler.decompose.source import HullSource
from svhdesc.compiler.pipeline.timings import Timings
from svhdesc.compiler.probes.keyframe_contacts import stop_at_contact
from svhdesc.compiler.probes.rest_contacts import exclude_touching
from svhdesc.compiler.probes.stability import check_servos
from svhdesc.compiler.stages.actuation import add_actuation, add_force_sensor, add_keyframes
from svhdesc.compiler.stages.collision_rules import collision_rules
from svhdesc.compiler.stages.contact import add_contact
from svhdesc.compiler.stages.coupled import Coupled, couple
from svhdesc.compiler.stages.finite import check_finite
from svhdesc.compiler.stages.geometry import Meshes, bake_meshes, decomposition_jobs
from svhdesc.compiler.stages.inertials import add_inertials
from svhdesc.compiler.stages.semantics import check_driven, check_hand_names, check_keyframes, check_unique_names
from svhdesc.compiler.stages.world import add_world
from svhdesc.core.settings.config import Config, Variant
from svhdesc.core.settings.coupling import load_spec, spec_from_mimics
from svhdesc.core.settings.schema import Settings
from svhdesc.core.settings.yamlio import where
from svhdesc.core.source import mount as mount_source
from svhdesc.core.source.packages import resolve_uri
from svhdesc.core.source.quirks import apply_joint_quirks
from svhdesc.core.source.urdf import SourceMimic, read_mimics, read_urdf
from svhdesc.core.source.xacro import expand_xacro
from svhdesc.errors import SvhdescError
from svhdesc.ir import HandId, Robot


@dataclass(frozen=True)
class Plan:
    """A variant read and planned, once: the source robot and what the processors need beside their settings."""

    variant: Variant
    robot: Robot  # as read: kinematics and geometry, nothing injected yet but its hand's prefix and side
    packages: dict[str, Path]  # the packages it was read with
    inputs: tuple[Path, ...]  # every file the build reads, for the manifest
    coupling: Coupled
    meshes: Meshes  # the collision rule of each link, and the hull source
    jobs: tuple[Any, ...]  # the decompositions the rules ask for, run across variants before any compile

    @property
    def settings(self) -> Settings:
        return self.variant.settings


@dataclass(frozen=True)
class Processor:
    stage: str  # its line in --timings
    process: Callable[[Robot, Assets, Any], Robot]
    section: Callable[[Plan], Any]  # what it reads


@dataclass(frozen=True)
class Check:
    check: Callable[..., None]  # check(robot, section), or check(robot) for one that reads the robot alone
    section: Callable[[Plan], Any] | None = None

    def run(self, robot: Robot, plan: Plan) -> None:
        if self.section is None:
            self.check(robot)
        else:
            self.check(robot, self.section(plan))


PROCESSORS: tuple[Processor, ...] = (
    Processor("coupling", couple, lambda plan: plan.coupling),
    Processor("meshes", bake_meshes, lambda plan: plan.meshes),
    Processor("inertials", add_inertials, lambda plan: (plan.settings.mass, plan.settings.hand)),
    Processor("physics", add_contact, lambda plan: (plan.settings.contact, plan.settings.hand)),
    Processor(
        "physics",
        add_actuation,
        lambda plan: (
            plan.settings.hand,
            plan.settings.arm,
            plan.settings.transmissions,
            plan.settings.joints,
            plan.settings.simulation.friction_cap,
        ),
    ),
    Processor("physics", add_keyframes, lambda plan: (plan.settings.keyframes, plan.settings.hand, plan.settings.arm)),
    Processor("physics", add_force_sensor, lambda plan: plan.settings.hand),
    Processor("physics", add_world, lambda plan: (plan.settings.simulation, plan.settings.scene)),
)

CHECKS: tuple[Check, ...] = (
    Check(check_hand_names, lambda plan: plan.settings.hand),
    Check(check_driven, lambda plan: plan.settings.arm),
    Check(check_keyframes, lambda plan: (plan.settings.keyframes, plan.settings.where)),
    Check(check_unique_names, lambda plan: (plan.settings.hand, plan.settings.arm)),
    Check(check_finite),
)

# These compile the model in MuJoCo: they run on a checked model, so that a check names the fault first.
SIMULATED: tuple[Processor, ...] = (
    Processor("exclusions", exclude_touching, lambda plan: plan.settings.collision),
    # a keyframe is a state a user loads: one whose fingers close into each other stops where they meet
    Processor("keyframes", stop_at_contact, lambda plan: None),
    # a model whose servos the timestep cannot integrate diverges: refused, never called built
    Processor("checks", check_servos, lambda plan: (plan.settings.arm.at("kp"), plan.settings.hand.at("kp"))),
)


@dataclass
class Compiled:
    plan: Plan
    robot: Robot
    assets: Assets


@dataclass(frozen=True)
class Source:
    robot: Robot  # as read
    inputs: list[Path]
    mimics: list[SourceMimic]  # the source's <mimic> tags: the coupling spec when the config gives none


def hand_of(variant: Variant) -> HandId:
    """The variant's hand: prefix and side as its settings resolve them (a mount's included). A ``side`` xacro
    argument that says otherwise is refused: the model would be the other hand."""
    hand = variant.settings.hand
    argued = variant.args.get("side")
    if hand.side is not None and argued in ("right", "left") and argued != hand.side:
        raise SvhdescError(f"{hand.at('side')}: hand.side is {hand.side}, but the xacro argument side is {argued}")
    return HandId(hand.prefix, hand.side)


def read_source(variant: Variant, packages: dict[str, Path], timings: Timings) -> Source:
    """The variant's robot as read, its ``joints:`` quirks applied, carrying its hand's prefix and side; with a
    ``mount``, the arm of its xacro with this project's hand grafted on."""
    hand_id = hand_of(variant)
    arm = _read(variant.xacro, variant.args, packages, timings, variant.settings.joints)
    mount = variant.settings.mount
    if mount is None:
        return replace(arm, robot=replace(arm.robot, name=variant.name, hand=hand_id))
    args = mount_source.hand_args(mount, str(hand_id.prefix))
    hand = _read(mount_source.hand_xacro(), args, mount_source.hand_packages(packages), timings)
    robot = replace(mount_source.graft(arm.robot, hand.robot, mount), name=variant.name, hand=hand_id)
    # the arm's own <mimic> tags only: the hand's couplings come from its spec
    return Source(robot, list(dict.fromkeys([*arm.inputs, *hand.inputs])), arm.mimics)


def _read(
    xacro: Path, args: dict[str, str], packages: dict[str, Path], timings: Timings, quirks: dict | None = None
) -> Source:
    with timings.stage("xacro"):
        tree, inputs = expand_xacro(xacro, args, packages)
    with timings.stage("read"):
        apply_joint_quirks(tree, quirks or {}, getattr(quirks, "lines", {}))
        robot = read_urdf(tree, packages, xacro, inputs)
    mimics = read_mimics(tree, xacro, inputs)
    return Source(robot, [*inputs, *_mesh_sources(tree, packages, xacro)], mimics)


def plan_variant(variant: Variant, extra_packages: dict[str, Path], hulls: HullSource | None, timings: Timings) -> Plan:
    """Read ``variant`` and decide its collision rules once: they serve the prefetch and the compile."""
    packages = {**variant.packages(), **extra_packages}
    if variant.settings.mount is not None:
        packages = mount_source.hand_packages(packages)
    source = read_source(variant, packages, timings)
    settings, hand = variant.settings, source.robot.hand
    spec_path = variant.coupling_path  # None: a robot without couplings
    widen = settings.coupled_limits == "widen"
    with timings.stage("coupling"):
        if spec_path is not None:
            spec, prefix = load_spec(spec_path), hand.prefix
        else:  # the source's own <mimic> tags, with the source's full joint names
            spec, prefix = spec_from_mimics(source.robot, source.mimics, variant.xacro, narrow=not widen), None
    coupled = Coupled(spec, prefix, widen, settings.hand.at("prefix"))
    rules = collision_rules(source.robot, settings.collision, hand.prefix)
    jobs = tuple(decomposition_jobs(source.robot, rules))
    inputs = (*source.inputs, *([spec_path] if spec_path is not None else []))
    return Plan(variant, source.robot, packages, inputs, coupled, Meshes(rules, hulls), jobs)


def compile_variant(plan: Plan, timings: Timings | None = None) -> Compiled:
    """The processors in order, then the checks, then the processors that simulate the checked model."""
    timings = timings or Timings()
    robot, assets = plan.robot, Assets()
    for processor in PROCESSORS:
        with timings.stage(processor.stage):
            robot = processor.process(robot, assets, processor.section(plan))
    with timings.stage("checks"):
        for check in CHECKS:
            check.run(robot, plan)
    for processor in SIMULATED:
        with timings.stage(processor.stage):
            robot = processor.process(robot, assets, processor.section(plan))
    return Compiled(plan, robot, assets)


def compile_variants(
    config: Config, names: list[str], extra_packages: dict[str, Path], hulls: HullSource, timings: Timings
) -> Iterator[Compiled]:
    """The selected variants compiled one after the other, once every decomposition they need has run (in
    parallel, across variants)."""
    plans = [plan_variant(variant, extra_packages, hulls, timings) for variant in config.select(names)]
    _check_mass_names(config, plans, extra_packages, timings)
    with timings.stage("decompose"):
        hulls.prefetch([job for p in plans for job in p.jobs])
    for each in plans:
        yield compile_variant(each, timings)


def _check_mass_names(config: Config, plans: list[Plan], extra_packages: dict[str, Path], timings: Timings) -> None:
    """mass.links/inertials written in this config may name links of another of its variants (shared
    settings), but not of none."""
    known = {p.variant.name: {link.name for link in p.robot.links} for p in plans}

    def links_of(variant: Variant) -> set[str]:
        if variant.name not in known:
            source = read_source(variant, {**variant.packages(), **extra_packages}, timings)
            known[variant.name] = {link.name for link in source.robot.links}
        return known[variant.name]

    for each in plans:
        mass = each.settings.mass
        explicit = mass.inertials if isinstance(mass.inertials, dict) else {}  # `inertials: recompute` names none
        for section, named in (("links", mass.links), ("inertials", explicit)):
            for name in named:
                at = where(named, str(config.path), name)
                # Only names written here: a base's (extends) shared names may serve variants not declared here.
                mine = at.startswith(f"{config.path}:")
                if mine and not any(name in links_of(v) for v in (each.variant, *config.variants.values())):
                    raise SvhdescError(f"{at}: mass.{section}: no link {name} in any variant")


def _mesh_sources(tree: etree._Element, packages: dict[str, Path], source: Path) -> list[Path]:
    paths = []
    for mesh in tree.iter("mesh"):
        path = resolve_uri(mesh.get("filename", ""), packages, str(source))
        paths.append((path if path.is_absolute() else source.parent / path).resolve())
    return sorted(set(paths))
