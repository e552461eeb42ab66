"""The package's layout rules: two wings, one contract between them, and the floor it stands on.

- runtime packages and validate, the contract (svhdesc/model.py) and the floor both wings read (svhdesc/core/)
  import nothing of svhdesc.compiler (cli.py alone drives both wings); the floor imports neither the contract nor
  the runtime;
- no module of the package imports its face (``import svhdesc``, ``from svhdesc import get``): the face is for
  users; a module imports the module that defines a name (svhdesc.model), so the face can import anything;
- no import cycle between svhdesc's modules (lazy and type-checking imports count: a cycle is a tangle either way);
- inside the compiler, each room keeps to its side (``APART``): a stage (a processor of the IR) imports no exporter,
  probe or pipeline; an exporter (a renderer of the IR and the probes' results) imports no stage, probe or pipeline;
  a probe imports no pipeline; the controller core (svhdesc/control/) imports neither the simulator (svhdesc.sim,
  mujoco) nor a transport (svhdesc.ros1, svhdesc.ros2, rospy, rclpy, ...): of what is not svhdesc, only the standard
  library and numpy (``CORE_MAY_IMPORT``);
- no module imports an underscore-private name (or module) of another package;
- at most MAX_ROOT_MODULES modules at the package root;
- one ``Coupling`` for a built model (svhdesc/model.py) beside the compiler IR's (svhdesc/ir.py).

Every module under svhdesc/ is parsed with ast (nothing imported); each rule is also shown to catch a seeded
violation in a synthetic source.
"""

from __future__ import annotations

import ast
import sys
from pathlib import Path

import pytest

from tests.support import REPO

PACKAGE = REPO / "svhdesc"
RUNTIME = ("loaders", "sim", "ros1", "ros2", "control", "plan", "compare", "wireloop", "batch", "learn", "validate")
NO_COMPILER = (*RUNTIME, "model", "core")  # what may not import svhdesc.compiler
FRONT = {"svhdesc", "svhdesc.cli"}  # the package face and the command line, that may import the face
COUPLING_HOMES = {"svhdesc.model", "svhdesc.ir"}
# package -> (package it may not import, why): the rooms of the compiler.
APART: dict[str, tuple[tuple[str, str], ...]] = {
    "svhdesc.compiler.stages": (
        ("svhdesc.compiler.export", "a stage processes the IR; what needs an exporter is a probe"),
        ("svhdesc.compiler.probes", "a stage processes the IR; the pipeline hands it a probe's result"),
        ("svhdesc.compiler.pipeline", "the pipeline runs the stages, not the other way"),
    ),
    "svhdesc.compiler.export": (
        ("svhdesc.compiler.stages", "an exporter renders the IR; what a stage computes is in it"),
        ("svhdesc.compiler.probes", "an exporter renders the probes' results (registry.Probed), it runs none"),
        ("svhdesc.compiler.pipeline", "the pipeline runs the exporters, not the other way"),
    ),
    "svhdesc.compiler.probes": (("svhdesc.compiler.pipeline", "the pipeline runs the probes, not the other way"),),
    "svhdesc.control": (
        ("svhdesc.sim", "the controller core reads the robot through control.trajectory.Hardware"),
        ("svhdesc.ros1", "the controller core is free of transports; ROS 1 wraps it"),
        ("svhdesc.ros2", "the controller core is free of transports; ROS 2 wraps it"),
    ),
}
# What the controller core may import besides svhdesc: no simulator (mujoco), no middleware (rospy, rclpy, ...).
CORE_MAY_IMPORT = {*sys.stdlib_module_names, "numpy"}
MAX_ROOT_MODULES = 10


def module_name(path: Path) -> str:
    parts = path.relative_to(PACKAGE.parent).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def package_of(module: str, is_package: bool) -> str:
    """The package a module belongs to (a package's __init__ belongs to itself)."""
    return module if is_package else module.rpartition(".")[0]


def imports(tree: ast.Module, module: str, is_package: bool) -> list[tuple[str, str | None, int]]:
    """(imported module, imported name or None, line) of every import, relative ones resolved."""
    found: list[tuple[str, str | None, int]] = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            found.extend((alias.name, None, node.lineno) for alias in node.names)
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                anchor = package_of(module, is_package).split(".")
                anchor = anchor[: len(anchor) - (node.level - 1)]
                base = ".".join([*anchor, base] if base else anchor)
            found.extend((base, alias.name, node.lineno) for alias in node.names)
    return found


def imported_package(target: str) -> str:
    """The package holding module ``target`` (a package holds itself)."""
    directory = PACKAGE.parent.joinpath(*target.split("."))
    return target if (directory / "__init__.py").is_file() else target.rpartition(".")[0]


def private_owner(target: str, name: str | None) -> tuple[str, str] | None:
    """(private name, package owning it) where the import reaches an underscore module or name, else None."""
    parts = target.split(".")
    for index, part in enumerate(parts[1:], 1):
        if part.startswith("_"):
            return part, ".".join(parts[:index])
    if name is not None and name.startswith("_"):
        return name, imported_package(target)
    return None


def is_module(dotted: str) -> bool:
    path = PACKAGE.parent.joinpath(*dotted.split("."))
    return path.with_suffix(".py").is_file() or (path / "__init__.py").is_file()


def imports_face(target: str, name: str | None) -> bool:
    """``import svhdesc`` or ``from svhdesc import NAME`` where NAME is not a module of the package."""
    return target == "svhdesc" and (name is None or not is_module(f"svhdesc.{name}"))


def within(module: str, package: str) -> bool:
    return module == package or module.startswith(f"{package}.")


def apart_problems(module: str, target: str) -> list[str]:
    """What importing ``target`` from ``module`` breaks of ``APART``."""
    return [
        f"imports {target}: {why}"
        for room, rules in APART.items()
        if within(module, room)
        for banned, why in rules
        if within(target, banned)
    ]


def violations(source: str, module: str, is_package: bool = False) -> list[str]:
    """What one module's source breaks of the import and Coupling rules."""
    tree = ast.parse(source)
    problems = []
    wing = module.split(".")[1] if "." in module else ""
    own_package = package_of(module, is_package)
    for target, name, line in imports(tree, module, is_package):
        if target != "svhdesc" and not target.startswith("svhdesc."):
            if within(module, "svhdesc.control") and target.split(".")[0] not in CORE_MAY_IMPORT:
                problems.append(f"{module}:{line}: the controller core imports {target} (stdlib and numpy only)")
            continue
        reaches_compiler = target == "svhdesc.compiler" or target.startswith("svhdesc.compiler.")
        if wing in NO_COMPILER and reaches_compiler:
            way = "go through svhdesc.model" if wing in RUNTIME else "what both wings read belongs in svhdesc.core"
            problems.append(f"{module}:{line}: imports the compiler ({target}); {way}")
        above = target.split(".")[1] if "." in target else ""
        if wing == "core" and (above == "model" or above in RUNTIME):
            problems.append(f"{module}:{line}: svhdesc.core imports {target}; the floor imports nothing above it")
        if module not in FRONT and imports_face(target, name):
            problems.append(f"{module}:{line}: imports the package face svhdesc; import svhdesc.model (or the module)")
        named = f"{target}.{name}" if name is not None and is_module(f"{target}.{name}") else target
        problems += [f"{module}:{line}: {problem}" for problem in apart_problems(module, named)]
        private = private_owner(target, name)
        if private is not None and private[1] != own_package:
            problems.append(f"{module}:{line}: imports the private {private[0]} of {private[1]}")
    for node in ast.walk(tree):
        if isinstance(node, ast.ClassDef) and node.name == "Coupling" and module not in COUPLING_HOMES:
            problems.append(f"{module}:{node.lineno}: defines a Coupling (the one for a built model: svhdesc.model)")
    return list(dict.fromkeys(problems))  # one line per import statement, however many names it takes


def import_graph(sources: dict[str, tuple[str, bool]]) -> dict[str, set[str]]:
    """Module -> the modules among ``sources`` it imports (``from package import module`` names the module)."""
    graph: dict[str, set[str]] = {}
    for module, (source, is_package) in sources.items():
        edges = set()
        for target, name, _ in imports(ast.parse(source), module, is_package):
            edges.add(f"{target}.{name}" if f"{target}.{name}" in sources else target)
        graph[module] = {edge for edge in edges if edge in sources and edge != module}
    return graph


def cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """One cycle (a -> b -> ... -> a) through each module that lies on one, found by depth-first search."""
    found: list[list[str]] = []
    done: set[str] = set()

    def visit(module: str, path: list[str]) -> None:
        if module in path:
            found.append([*path[path.index(module) :], module])
            return
        if module in done:
            return
        for target in sorted(graph[module]):
            visit(target, [*path, module])
        done.add(module)

    for module in sorted(graph):
        visit(module, [])
    return found


def root_problems(package: Path) -> list[str]:
    root = sorted(p.name for p in package.glob("*.py"))
    return [f"{len(root)} modules at the root of {package.name}/ (at most {MAX_ROOT_MODULES}): {root}"] * (
        len(root) > MAX_ROOT_MODULES
    )


def modules() -> list[Path]:
    return sorted(PACKAGE.rglob("*.py"))


def test_no_module_breaks_the_import_and_coupling_rules() -> None:
    problems = []
    for path in modules():
        problems += violations(path.read_text(), module_name(path), path.name == "__init__.py")
    assert not problems, "\n".join(problems)


def test_no_import_cycle_between_modules() -> None:
    sources = {module_name(p): (p.read_text(), p.name == "__init__.py") for p in modules()}
    assert cycles(import_graph(sources)) == []


def test_a_seeded_cycle_is_caught() -> None:
    """Two modules importing each other (one lazily, one under TYPE_CHECKING), and a longer loop through a package."""
    pair = {
        "svhdesc.validate.check": ("def f():\n    from svhdesc.validate.plots import plot\n", False),
        "svhdesc.validate.plots": (
            "from typing import TYPE_CHECKING\nif TYPE_CHECKING:\n    from .check import Run\n",
            False,
        ),
        "svhdesc.validate.other": ("from svhdesc.validate import plots\n", False),
    }
    assert cycles(import_graph(pair)) == [
        ["svhdesc.validate.check", "svhdesc.validate.plots", "svhdesc.validate.check"]
    ]
    loop = {
        "svhdesc.sim": ("from svhdesc.sim.runtime import Simulation\n", True),
        "svhdesc.sim.runtime": ("from svhdesc.sim import objects\n", False),
        "svhdesc.sim.objects": ("import svhdesc.sim\n", False),
    }
    (cycle,) = cycles(import_graph(loop))
    assert cycle == ["svhdesc.sim", "svhdesc.sim.runtime", "svhdesc.sim.objects", "svhdesc.sim"]
    loop["svhdesc.sim.objects"] = ("import numpy\n", False)
    assert cycles(import_graph(loop)) == []


def test_the_package_root_holds_at_most_ten_modules() -> None:
    assert root_problems(PACKAGE) == []


def test_every_runtime_package_exists() -> None:
    # A renamed package would make the compiler rule vacuous for it.
    assert all((PACKAGE / name / "__init__.py").is_file() for name in RUNTIME)


@pytest.mark.parametrize(
    ("source", "module", "expected"),
    [
        (
            "from svhdesc.compiler.pipeline.steps import compile_variants\n",
            "svhdesc.validate.pair",
            "imports the compiler",
        ),
        ("import svhdesc.compiler.export.urdf\n", "svhdesc.sim.robot", "imports the compiler"),
        ("def f():\n    from svhdesc.compiler import exact\n", "svhdesc.ros1.node", "imports the compiler"),
        ("from ..compiler.pipeline import steps\n", "svhdesc.validate.pair", "imports the compiler"),
        ("from svhdesc.compiler.stages.geometry import bake_meshes\n", "svhdesc.model", "imports the compiler"),
        ("def f():\n    from svhdesc.compiler.pipeline import builder\n", "svhdesc.model", "imports the compiler"),
        ("from svhdesc.compiler.stages import world\n", "svhdesc.core.settings.schema", "imports the compiler"),
        ("from svhdesc.model import get\n", "svhdesc.core.manifest", "imports nothing above it"),
        ("def f():\n    from svhdesc.sim import Simulation\n", "svhdesc.core.frames", "imports nothing above it"),
        ("from svhdesc import get\n", "svhdesc.loaders.mujoco", "imports the package face"),
        ("def f():\n    import svhdesc\n", "svhdesc.plan.ik", "imports the package face"),
        ("from .. import get\n", "svhdesc.sim.runtime", "imports the package face"),
        ("import svhdesc\n", "svhdesc.model", "imports the package face"),
        ("from svhdesc.validate.render import _write_png\n", "svhdesc.wireloop.mujoco_run", "private _write_png"),
        (
            "from svhdesc.loaders._common import couplings\n",
            "svhdesc.compare.engine",
            "private _common of svhdesc.loaders",
        ),
        ("from svhdesc.loaders import _common\n", "svhdesc.compare.engine", "private _common"),
        ("from dataclasses import dataclass\nclass Coupling:\n    pass\n", "svhdesc.sim.robot", "defines a Coupling"),
        # the compiler's rooms: stages, exporters, probes, pipeline
        (
            "from svhdesc.compiler.export.mjcf import export_mjcf\n",
            "svhdesc.compiler.stages.coupled",
            "a stage processes the IR; what needs an exporter is a probe",
        ),
        ("from svhdesc.compiler import probes\n", "svhdesc.compiler.stages.excludes", "the pipeline hands it"),
        ("from svhdesc.compiler.pipeline import steps\n", "svhdesc.compiler.stages", "the pipeline runs the stages"),
        (
            "from svhdesc.compiler.stages.coupled import mimic_order_problems\n",
            "svhdesc.compiler.export.urdf",
            "an exporter renders the IR; what a stage computes is in it",
        ),
        (
            "def f():\n    from svhdesc.compiler.probes.collision_matrix import cached_collision_matrix\n",
            "svhdesc.compiler.export.registry",
            "it runs none",
        ),
        ("from ..pipeline.timings import Timings\n", "svhdesc.compiler.export.batch", "runs the exporters"),
        ("from svhdesc.compiler.pipeline.timings import Timings\n", "svhdesc.compiler.probes.cache", "runs the probes"),
        # the controller core: no simulator, no transport
        (
            "from svhdesc.sim import Point, Simulation, State\n",
            "svhdesc.control.trajectory",
            "control.trajectory.Hardware",
        ),
        ("from svhdesc.sim.trajectory import Point\n", "svhdesc.control.goals", "control.trajectory.Hardware"),
        ("def f():\n    from svhdesc.ros2 import node\n", "svhdesc.control.work", "ROS 2 wraps it"),
        ("from ..ros1.messages import control_msgs\n", "svhdesc.control.manager", "ROS 1 wraps it"),
        ("import mujoco\n", "svhdesc.control.trajectory", "imports mujoco (stdlib and numpy only)"),
        ("def f():\n    import rclpy.action\n", "svhdesc.control.forward", "imports rclpy.action"),
        ("from rospy import Duration\n", "svhdesc.control", "imports rospy"),
    ],
)
def test_a_seeded_violation_is_caught(source: str, module: str, expected: str) -> None:
    (problem,) = violations(source, module)
    assert expected in problem


@pytest.mark.parametrize(
    ("source", "module"),
    [
        ("from svhdesc.core.source.packages import local_mesh_path\n", "svhdesc.model"),
        ("from svhdesc.core.settings.schema import Mount\n", "svhdesc.compiler.stages.world"),
        ("from svhdesc.errors import SvhdescError\nfrom svhdesc.ir import Robot\n", "svhdesc.core.source.urdf"),
        ("from svhdesc.compiler.pipeline import builder\n", "svhdesc.cli"),
        ("def f():\n    import svhdesc\n", "svhdesc.cli"),
        ("from svhdesc import loaders\n", "svhdesc"),
        ("from svhdesc import model\n", "svhdesc.sim.runtime"),
        ("from svhdesc.model import get\n", "svhdesc.loaders.mujoco"),
        ("from svhdesc.compiler.decompose.cache import _entry_meta\n", "svhdesc.compiler.decompose.pool"),
        ("from svhdesc.loaders._common import couplings\n", "svhdesc.loaders.dart"),
        ("from svhdesc.sim import Simulation\n", "svhdesc.ros1.node"),
        ("from svhdesc.extras import require as _require\n", "svhdesc.loaders._common"),
        ("class Coupling:\n    pass\n", "svhdesc.ir"),
        ("from svhdesc.compiler.export.mjcf import export_mjcf\n", "svhdesc.compiler.probes.damping"),
        ("from svhdesc.compiler.stages.excludes import add_excludes\n", "svhdesc.compiler.probes.rest_contacts"),
        ("from svhdesc.compiler.assets import Assets\n", "svhdesc.compiler.export.registry"),
        ("from svhdesc.compiler.assets import Assets\n", "svhdesc.compiler.stages.world"),
        ("from svhdesc.compiler.probes import probe\n", "svhdesc.compiler.pipeline.builder"),
        ("from svhdesc.compiler.export.registry import OUTPUTS\n", "svhdesc.compiler.pipeline.builder"),
        ("import numpy as np\nimport threading\nfrom typing import Protocol\n", "svhdesc.control.trajectory"),
        (
            "from svhdesc.control.spline import Point\nfrom svhdesc.errors import SvhdescError\n",
            "svhdesc.control.goals",
        ),
        ("from svhdesc.control.trajectory import JointTrajectoryCore\n", "svhdesc.ros2.controller"),
        ("import mujoco\n", "svhdesc.sim.runtime"),
    ],
)
def test_what_the_rules_allow_passes(source: str, module: str) -> None:
    assert violations(source, module) == []


def test_a_crowded_root_is_caught(tmp_path: Path) -> None:
    for index in range(MAX_ROOT_MODULES):
        (tmp_path / f"m{index}.py").write_text("")
    (tmp_path / "sub").mkdir()
    (tmp_path / "sub" / "deep.py").write_text("")  # a subpackage's modules do not count
    assert root_problems(tmp_path) == []
    (tmp_path / "one_more.py").write_text("")
    assert len(root_problems(tmp_path)) == 1
