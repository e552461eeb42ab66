"""The loads `svhdesc init` sizes drives with (``compiler/loads.py``), against Pinocchio's dynamics of the same URDF:
each joint's gravity load is minus RNEA's torque at rest (zero velocity and acceleration), its inertia the CRBA mass
matrix's diagonal, its mobility the diagonal of that matrix's inverse. A random tree with revolute, prismatic and
fixed joints, tilted axes, inertials turned by rpy and branches, at a random pose.

The passes are linear in the number of links: a test counts the spatial products (``exact.matmul``) per joint for
chains of 20 and 80 links and 40 siblings: constant (the walk over each joint's subtree and the n x n mass matrix
that issue 48 found cubic in the depth counted 184 a joint at 20 links and 2,304 at 80). Seeded faults, each
failing the Pinocchio test: the subtree's first moment not shifted to the parent's origin (gravity off), ``P^T``
dropped from the compliance pass (mobilities off below the first joint).
"""

from __future__ import annotations

import random
from pathlib import Path

import numpy as np
import pytest
from lxml import etree

from svhdesc.compiler import loads
from svhdesc.core import exact
from svhdesc.core.source.urdf import read_urdf

pin = pytest.importorskip("pinocchio")


def _numbers(rng: random.Random, n: int, scale: float) -> str:
    return " ".join(f"{rng.uniform(-scale, scale):.6f}" for _ in range(n))


def _inertial(link: etree._Element, rng: random.Random) -> None:
    inertial = etree.SubElement(link, "inertial")
    etree.SubElement(inertial, "origin", xyz=_numbers(rng, 3, 0.1), rpy=_numbers(rng, 3, 1.0))
    etree.SubElement(inertial, "mass", value=f"{rng.uniform(0.2, 2.0):.6f}")
    a, b, c = (rng.uniform(0.002, 0.02) for _ in range(3))  # principal moments obeying the triangle inequality
    values = {"ixx": b + c, "iyy": a + c, "izz": a + b, "ixy": 0.0, "ixz": 0.0, "iyz": 0.0}
    etree.SubElement(inertial, "inertia", {k: f"{v:.6f}" for k, v in values.items()})


def _joint(robot: etree._Element, name: str, parent: str, child: str, kind: str, rng: random.Random) -> None:
    joint = etree.SubElement(robot, "joint", name=name, type=kind)
    etree.SubElement(joint, "origin", xyz=_numbers(rng, 3, 0.3), rpy=_numbers(rng, 3, 1.5))
    etree.SubElement(joint, "parent", link=parent)
    etree.SubElement(joint, "child", link=child)
    if kind != "fixed":
        etree.SubElement(joint, "axis", xyz=_numbers(rng, 3, 1.0))
        etree.SubElement(joint, "limit", lower="-3", upper="3", effort="10", velocity="1")


def random_tree(path: Path, seed: int = 7, links: int = 14) -> Path:
    """A URDF tree of ``links`` links hung from 'base': each new link on a random earlier one."""
    rng = random.Random(seed)
    robot = etree.Element("robot", name="tree")
    etree.SubElement(robot, "link", name="base")
    names = ["base"]
    for i in range(1, links + 1):
        link = etree.SubElement(robot, "link", name=f"l{i}")
        _inertial(link, rng)
        kind = rng.choice(["revolute", "revolute", "prismatic", "fixed"])
        _joint(robot, f"j{i}", rng.choice(names), f"l{i}", kind, rng)
        names.append(f"l{i}")
    path.write_bytes(etree.tostring(robot, pretty_print=True, xml_declaration=True))
    return path


@pytest.fixture(scope="module")
def tree(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, object, dict, dict]:
    path = random_tree(tmp_path_factory.mktemp("loads") / "tree.urdf")
    robot = read_urdf(etree.parse(str(path)).getroot(), {}, path)
    masses = {link.name: link.inertial for link in robot.links if link.inertial is not None}
    rng = random.Random(3)
    pose = {j.name: rng.uniform(-1.5, 1.5) for j in robot.joints if j.movable}
    return path, robot, masses, pose


def _pinocchio(path: Path, pose: dict[str, float]) -> tuple[list[str], np.ndarray, np.ndarray]:
    """Pinocchio's joint names, gravity torques g(q) and mass matrix M(q) at ``pose``."""
    model = pin.buildModelFromUrdf(str(path))
    data = model.createData()
    names = list(model.names)[1:]
    q = np.array([pose[name] for name in names])
    zero = np.zeros(model.nv)
    return names, pin.rnea(model, data, q, zero, zero).copy(), pin.crba(model, data, q).copy()


def test_loads_match_pinocchio(tree: tuple[Path, object, dict, dict]) -> None:
    path, robot, masses, pose = tree
    names, torque, matrix = _pinocchio(path, pose)
    matrix = np.triu(matrix) + np.triu(matrix, 1).T  # crba fills the upper triangle
    found = loads.joint_loads(robot, pose, masses)
    assert sorted(found) == sorted(names)
    gravity = np.array([found[n].gravity for n in names])
    inertia = np.array([found[n].inertia for n in names])
    assert np.allclose(gravity, -torque, rtol=1e-9, atol=1e-9), (gravity, -torque)
    assert np.allclose(inertia, np.diag(matrix), rtol=1e-9, atol=1e-12)
    mobility = loads.mobilities(robot, pose, masses)
    expected = np.diag(np.linalg.inv(matrix))
    assert np.allclose([mobility[n] for n in names], expected, rtol=1e-7), ([mobility[n] for n in names], expected)


def _chain(links: int, siblings: bool = False) -> tuple[object, dict]:
    robot = etree.Element("robot", name="chain")
    etree.SubElement(robot, "link", name="base")
    rng = random.Random(1)
    for i in range(1, links + 1):
        link = etree.SubElement(robot, "link", name=f"l{i}")
        _inertial(link, rng)
        _joint(robot, f"j{i}", "base" if siblings else ("base" if i == 1 else f"l{i - 1}"), f"l{i}", "revolute", rng)
    source = Path("chain.urdf")
    ir = read_urdf(robot, {}, source)
    return ir, {link.name: link.inertial for link in ir.links if link.inertial is not None}


def _products(robot: object, masses: dict, monkeypatch: pytest.MonkeyPatch) -> int:
    count = [0]
    original = exact.matmul

    def counted(a: np.ndarray, b: np.ndarray) -> np.ndarray:
        count[0] += 1
        return original(a, b)

    monkeypatch.setattr(exact, "matmul", counted)
    pose = {j.name: 0.1 for j in robot.joints}  # type: ignore[attr-defined]
    loads.joint_loads(robot, pose, masses)  # type: ignore[arg-type]
    loads.mobilities(robot, pose, masses)  # type: ignore[arg-type]
    monkeypatch.setattr(exact, "matmul", original)
    return count[0]


def test_loads_are_linear_in_the_links(monkeypatch: pytest.MonkeyPatch) -> None:
    per_joint = {}
    for links, siblings in ((20, False), (80, False), (40, True)):
        robot, masses = _chain(links, siblings)
        per_joint[(links, siblings)] = _products(robot, masses, monkeypatch) / links
    assert per_joint[(80, False)] <= per_joint[(20, False)] * 1.05, per_joint
    assert per_joint[(40, True)] <= per_joint[(20, False)] * 1.05, per_joint
