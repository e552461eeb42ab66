"""IR -> the batch model for MuJoCo Warp and MJX: ``<variant>_batch.xml`` and ``scene_batch.xml``.

The same robot as ``<variant>.xml`` (kinematics, masses, couplings, actuators, sensors, keyframes all come
from the same tree) with what batched engines need stated instead of left to defaults:

- options both Warp and MJX implement: Newton solver, elliptic cone, implicitfast integrator, and no noslip
  pass (neither has one that matches MuJoCo C's; Warp would otherwise ignore it without a word);
- settings MuJoCo C and Warp then share instead of each choosing its own: solver tolerance BATCH_TOLERANCE (Warp
  raises any smaller one to it for float32), and no multi-contact convex collision (``multiccd``, on by default
  in MuJoCo C): both implement it, but they decide differently whether two hulls touch face on. At the first
  touch of middle and index finger (equivalence test, world 8) C gave two coincident contacts with a normal
  5 degrees from Warp's single one; the worlds then parted by 1.6e-3 rad in 1 s. Without it both compute the
  same single contact (benchmarks/batch_first_contacts.py) and that world stays within 5e-5 rad;
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from lxml import etree

from svhdesc.compiler.export.mjcf import collision_meshes, mjcf_tree, scene_tree
from svhdesc.compiler.export.xmlfmt import serialise
from svhdesc.ir import Robot
from svhdesc.model import BATCH_MAX_HULL_VERTICES, BATCH_OPTIONS, BATCH_TOLERANCE, batch_model_file

SIZE_MARGIN = 2.0  # capacities = margin x the sampled worst case, rounded up to a multiple of SIZE_STEP
SIZE_STEP = 8
FLAGS = {"multiccd": "disable"}


@dataclass(frozen=True)
class Capacities:
    """Per-world capacities and the sampled worst case they were sized from."""

    nconmax: int
    njmax: int
    worst_ncon: int  # contacts
    worst_candidates: int  # broadphase candidates (Warp stores them in the contact buffer)
    worst_nefc: int  # constraint rows

    @classmethod
    def from_worst_case(cls, worst_ncon: int, worst_candidates: int, worst_nefc: int) -> Capacities:
        def size(worst: int) -> int:
            return max(SIZE_STEP, math.ceil(SIZE_MARGIN * worst / SIZE_STEP) * SIZE_STEP)

        nconmax = size(max(worst_ncon, worst_candidates))
        return cls(nconmax, size(worst_nefc), worst_ncon, worst_candidates, worst_nefc)


def batch_tree(robot: Robot, capacities: Capacities | None) -> etree._Element:
    """The batch MJCF; without capacities (the build's first pass, which samples them) no ``<size>``."""
    root = mjcf_tree(robot)
    root.set("model", f"{robot.name}_batch")
    option = root.find("option")
    option.attrib.pop("noslip_iterations", None)
    for key, value in BATCH_OPTIONS.items():
        option.set(key, value)
    option.set("tolerance", f"{BATCH_TOLERANCE:g}")
    flag = option.find("flag")
    if flag is None:
        flag = etree.SubElement(option, "flag")
    for key, value in FLAGS.items():
        flag.set(key, value)
    if capacities is not None:
        option.addnext(
            etree.Comment(
                f" Per-world capacities for MuJoCo Warp / MJX: {SIZE_MARGIN:g} x the worst case of sampled rollouts "
                f"(contacts {capacities.worst_ncon}, broadphase candidates {capacities.worst_candidates}, "
                f"constraint rows {capacities.worst_nefc}). "
                "Raise them when adding objects. "
            )
        )
        option.getnext().addnext(etree.Element("size", nconmax=str(capacities.nconmax), njmax=str(capacities.njmax)))
    hulls = collision_meshes(robot)
    for mesh in root.iterfind("asset/mesh"):
        if mesh.get("name") in hulls:
            mesh.set("maxhullvert", str(BATCH_MAX_HULL_VERTICES))
    for cls in root.iterfind(".//default[@class='collision']/geom"):
        cls.set("contype", "1")
        cls.set("conaffinity", "1")
    return root


def export_batch(robot: Robot, capacities: Capacities | None) -> bytes:
    return serialise(batch_tree(robot, capacities))


def export_batch_scene(robot: Robot) -> bytes:
    root = scene_tree(robot, batch_model_file(robot.name))
    root.set("model", f"{robot.name} batch scene")
    for geom in root.iterfind("worldbody/geom"):  # floor, pedestal: collide with the robot, stated
        geom.set("contype", "1")
        geom.set("conaffinity", "1")
        if geom.get("type") == "cylinder":
            # MJX has no cylinder-mesh collision: the pedestal becomes the square box around the cylinder.
            radius, half_height = geom.get("size").split()
            geom.set("type", "box")
            geom.set("size", f"{radius} {radius} {half_height}")
    return serialise(root)
