"""Inertials from geometry: a cylinder fitted along each link's principal axis, masses from a budget."""

from __future__ import annotations

import fnmatch
import math
import warnings
from dataclasses import replace

import numpy as np
import trimesh

from svhdesc.compiler.assets import Assets
from svhdesc.core import exact
from svhdesc.core.frames import axis_frame, pose_matrix
from svhdesc.core.inertia import inertial_problem as problem_of
from svhdesc.core.settings.schema import Hand, Mass, expand_hand
from svhdesc.core.source.meshes import principal_cylinder
from svhdesc.errors import SvhdescError
from svhdesc.ir import Geometry, Inertial, Link, Robot


def shape_of(geometry: Geometry, assets: Assets) -> trimesh.Trimesh:
    if geometry.kind == "mesh":
        mesh = assets.meshes[geometry.mesh or ""].copy()
    elif geometry.kind == "box":
        mesh = trimesh.creation.box(extents=geometry.size)
    elif geometry.kind == "cylinder":
        mesh = trimesh.creation.cylinder(radius=geometry.size[0], height=geometry.size[1])
    elif geometry.kind == "sphere":
        mesh = trimesh.creation.icosphere(radius=geometry.size[0])
    elif geometry.kind == "capsule":
        mesh = trimesh.creation.capsule(radius=geometry.size[0], height=geometry.size[1])
    else:
        raise SvhdescError(f"cannot fit an inertial to geometry kind {geometry.kind}")
    mesh.apply_transform(pose_matrix(geometry.origin))
    return mesh


def link_solid(link: Link, assets: Assets) -> trimesh.Trimesh:
    """The link's solid in its own frame: collision shapes, or visual ones if it has none."""
    shapes = [shape_of(g, assets) for g in (link.collisions or link.visuals)]
    return trimesh.util.concatenate(shapes)


def cylinder_inertial(solid: trimesh.Trimesh, mass: float) -> Inertial:
    """1/2 m r^2 about the fitted axis, m (3 r^2 + l^2) / 12 about the others, in the link frame."""
    centre, axis, radius, length = principal_cylinder(solid)
    rotation = axis_frame(axis)
    transverse = mass * (3.0 * radius**2 + length**2) / 12.0
    principal = np.diag([transverse, transverse, 0.5 * mass * radius**2])
    tensor = exact.matmul(exact.matmul(rotation, principal), rotation.T)
    tensor = 0.5 * (tensor + tensor.T)
    values = (tensor[0, 0], tensor[0, 1], tensor[0, 2], tensor[1, 1], tensor[1, 2], tensor[2, 2])
    return Inertial(float(mass), tuple(float(c) for c in centre), tuple(float(x) for x in values))  # type: ignore[arg-type]


def inertial_problem(inertial: Inertial) -> str | None:
    """What makes an inertial unphysical (``svhdesc.core.inertia``); None for a valid one."""
    return problem_of(inertial.mass, inertial.inertia)


def check_inertial(inertial: Inertial, where: str) -> None:
    """Positive mass, positive definite tensor, triangle inequality of the principal moments."""
    problem = inertial_problem(inertial)
    if problem is not None:
        raise SvhdescError(f"{where}: {problem}")


class InertialWarning(UserWarning):
    """A source inertial was replaced by one computed from the link's geometry."""


def add_inertials(robot: Robot, assets: Assets, section: tuple[Mass, Hand]) -> Robot:
    mass, hand = section
    hand_prefix = hand.prefix
    explicit_full = mass.explicit_inertials
    solids = {link.name: link_solid(link, assets) for link in robot.links if link.has_geometry}
    masses = _masses(robot, solids, mass, set(explicit_full), hand_prefix)
    tiny = needs_tiny_mass(robot) - set(explicit_full)
    _check_recompute_names(robot, mass)
    links = []
    for link in robot.links:
        if link.name in explicit_full:
            spec = explicit_full[link.name]
            inertial = Inertial(float(spec["mass"]), tuple(spec["com"]), tuple(spec["inertia"]))  # type: ignore[arg-type]
        elif link.name not in solids and (link.name in mass.links or _invalid_frame(link, mass)):
            inertial = _frame_inertial(link, mass)  # a geometry-less link: nothing to fit a cylinder to
        elif link.inertial is not None:
            inertial = _from_source(link, solids, mass)  # explicit in the source, or recomputed
        elif link.name in solids:
            if link.name not in masses:
                raise SvhdescError(f"link {link.name} has geometry but no mass: add it to a budget or mass.links")
            inertial = cylinder_inertial(solids[link.name], masses[link.name])
        elif link.name in tiny:
            inertial = TINY_INERTIAL
        else:
            inertial = None
        if inertial is not None:
            check_inertial(inertial, f"link {link.name}")
        links.append(replace(link, inertial=inertial))
    return replace(robot, links=tuple(links))


def _masses(
    robot: Robot, solids: dict[str, trimesh.Trimesh], mass: Mass, explicit_full: set[str], hand_prefix: str | None
) -> dict[str, float]:
    """Link masses: explicit ones, the tiny mass of geometry-less links, then each budget split by volume."""
    masses: dict[str, float] = {n: float(m) for n, m in mass.links.items() if n in solids}
    tiny = needs_tiny_mass(robot) - explicit_full
    masses.update({name: float(mass.links.get(name, TINY_MASS)) for name in tiny})
    for budget in mass.budgets:
        pattern = expand_hand(str(budget["links"]), hand_prefix, budget.lines.get("links", budget.where))
        members = [n for n in [*solids, *sorted(tiny)] if fnmatch.fnmatchcase(n, pattern)]
        fixed = sum(masses.get(n, 0.0) for n in members)
        free = [n for n in members if n not in masses]
        remaining = float(budget["total"]) - fixed
        if members and (remaining <= 0 or not free):
            raise SvhdescError(f"mass budget {pattern}: explicit masses {fixed} kg leave nothing of {budget['total']}")
        volumes = {n: abs(exact.mass_properties(solids[n].vertices, solids[n].faces)[0]) for n in free}
        volume = math.fsum(volumes[n] for n in free)
        for name in free:
            masses[name] = remaining * volumes[name] / volume
    return masses


def _check_recompute_names(robot: Robot, mass: Mass) -> None:
    """A link named for recompute must be one whose source gives an inertial, with geometry to fit."""
    links = {link.name: link for link in robot.links}
    for name in sorted(mass.recompute_links):
        link = links.get(name)
        at = mass.inertials.lines.get(name, mass.at("inertials"))  # type: ignore[union-attr]
        if link is None:
            continue  # another variant's link (names are checked across the config's variants)
        if link.inertial is None and link.has_geometry:
            raise SvhdescError(f"{at}: mass.inertials.{name}: recompute: link {name} has no inertial in its source")


def _from_source(link: Link, solids: dict[str, trimesh.Trimesh], mass: Mass) -> Inertial:
    """The source's inertial, or, where the settings say `recompute`, the cylinder fitted to the link's
    geometry at the link's mass (mass.links, else the source's own), with a warning."""
    assert link.inertial is not None
    problem = inertial_problem(link.inertial)
    asked = link.name in mass.recompute_links
    if not asked and not problem:
        return link.inertial
    weight = float(mass.links.get(link.name, link.inertial.mass))  # the tensor is what is wrong, not the mass
    stated = ""
    if weight <= 0:  # a massless part with geometry (a marker, a sensor housing): the frames' tiny mass
        weight, stated = TINY_MASS, f" (the source's mass is {link.inertial.mass:g}: the tiny mass of frames)"
    reason = f"source inertial invalid ({problem})" if problem else "source inertial replaced as configured"
    warnings.warn(
        f"link {link.name}: {reason}; recomputed as a cylinder of {weight:g} kg{stated} fitted to its geometry",
        InertialWarning,
        stacklevel=2,
    )
    return cylinder_inertial(solids[link.name], weight)


TINY_MASS = 1e-4  # kg: valid everywhere, negligible against a 7 g fingertip
TINY_INERTIAL = Inertial(TINY_MASS, (0.0, 0.0, 0.0), (1e-9, 0.0, 0.0, 1e-9, 0.0, 1e-9))
FRAME_RADIUS = 0.01  # m: the solid sphere a geometry-less link's configured mass is spread over


def _invalid_frame(link: Link, mass: Mass) -> bool:
    """A geometry-less link whose source inertial is invalid (panda_link8's mass 0) or is to be recomputed."""
    if link.inertial is None:
        return False
    return link.name in mass.recompute_links or inertial_problem(link.inertial) is not None


def _frame_inertial(link: Link, mass: Mass) -> Inertial:
    """A geometry-less link's inertial, with one warning naming it: its configured mass (mass.links) as a solid
    sphere of FRAME_RADIUS, else its source's mass if > 0, else the tiny inertial every frame gets; at the
    source's centre of mass where it gives one."""
    source = link.inertial
    centre = source.com if source is not None else (0.0, 0.0, 0.0)
    weight = float(mass.links.get(link.name, source.mass if source is not None else 0.0))
    if weight <= 0:
        problem = inertial_problem(source) if source is not None else "no inertial"
        warnings.warn(
            f"link {link.name}: no geometry and source inertial invalid ({problem}); "
            f"given the tiny inertial of frames ({TINY_MASS:g} kg, 1e-9 kg m^2)",
            InertialWarning,
            stacklevel=3,
        )
        return replace(TINY_INERTIAL, com=centre)
    moment = 0.4 * weight * FRAME_RADIUS**2
    how = "mass.links" if link.name in mass.links else "its source's mass"
    warnings.warn(
        f"link {link.name}: no geometry; its inertial is a solid sphere of {weight:g} kg ({how}), "
        f"radius {FRAME_RADIUS:g} m",
        InertialWarning,
        stacklevel=3,
    )
    return Inertial(weight, centre, (moment, 0.0, 0.0, moment, 0.0, moment))


def needs_tiny_mass(robot: Robot) -> set[str]:
    """Every geometry-less link without a source inertial, except the root.

    Consumers disagree on what an inertial-less link is: sdformat drops a joint whose parent link is
    massless, MuJoCo needs mass on a moving body, and pybullet and DART give such a link 1 kg and a unit
    inertia (a 5.3 kg hand, and a broken j5 coupling in DART). Merging the links away would drop frames
    people use (tool0, flange, base; the palm helper frames of the vendor tree), so each gets a negligible
    mass instead. The root (a URDF 'world' link) stays massless: every consumer treats it as the world.
    """
    return {
        link.name for link in robot.links if not link.has_geometry and link.inertial is None and link.name != robot.root
    }
