"""The pipeline owner: one plan per variant (collision rules decided once), processors then checks, and the
outputs a build writes are exactly the registry's."""

from __future__ import annotations

import stat
from pathlib import Path

import pytest

from svhdesc.compiler import probes
from svhdesc.compiler.decompose import HullCache
from svhdesc.compiler.decompose.source import HullSource
from svhdesc.compiler.export.registry import OUTPUTS, PROBES, Probed, probes_wanted
from svhdesc.compiler.pipeline import steps
from svhdesc.compiler.pipeline.builder import write_variant
from svhdesc.compiler.pipeline.timings import Timings
from svhdesc.core.settings.config import load_config
from svhdesc.errors import SvhdescError
from svhdesc.ir import Robot
from tests.support import TESTS

MINI = TESTS / "data" / "mini" / "mini.yaml"


def compiled(tmp_path: Path) -> list[steps.Compiled]:
    hulls = HullSource(HullCache(tmp_path / "hulls"))
    return list(steps.compile_variants(load_config(MINI), [], {}, hulls, Timings()))


def test_collision_rules_are_decided_once_per_variant(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    decided = []
    rules = steps.collision_rules
    monkeypatch.setattr(steps, "collision_rules", lambda *args: decided.append(rules(*args)) or decided[-1])
    (result,) = compiled(tmp_path)
    assert len(decided) == 1  # the plan's rules serve the prefetch and the compile
    assert result.plan.meshes.rules is decided[0] and "right_hand_t" in decided[0]


def test_checks_run_after_every_processor(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """A check sees the finished model (world, sensor, keyframes), and nothing simulates a model that failed one."""
    seen: list[Robot] = []
    monkeypatch.setattr(steps, "CHECKS", (steps.Check(seen.append),))
    probed = []
    monkeypatch.setattr(
        steps, "SIMULATED", (steps.Processor("exclusions", lambda r, a, s: probed.append(r) or r, lambda p: 0),)
    )
    compiled(tmp_path)
    assert seen[0].physics.timestep == 0.001 and seen[0].sensors and seen[0].keyframes and probed

    def refuse(robot: Robot) -> None:
        raise SvhdescError("refused")

    probed.clear()
    monkeypatch.setattr(steps, "CHECKS", (steps.Check(refuse),))
    with pytest.raises(SvhdescError, match="refused"):
        compiled(tmp_path)
    assert probed == []


def test_a_build_writes_exactly_the_registry_outputs(tmp_path: Path) -> None:
    (result,) = compiled(tmp_path)
    directory = tmp_path / "mini"
    write_variant(result, directory, (), Timings())
    written = {
        p.relative_to(directory).as_posix()
        for p in directory.rglob("*")
        if p.is_file() and p.parent.name != "assets" and p.name != "manifest.json"
    }
    assert written == {output.name.format(robot="mini") for output in OUTPUTS}
    for output in OUTPUTS:
        mode = (directory / output.name.format(robot="mini")).stat().st_mode
        assert bool(mode & stat.S_IXUSR) == output.executable, output.name
    # MoveIt's files plan a hand: a robot without channels gets none, and so no collision matrix is sampled for it.
    bare = Robot(name="bare", links=(), joints=(), root="")
    assert {o.name for o in OUTPUTS if not o.when(bare)} >= {"config/{robot}.srdf", "launch/moveit.launch"}
    assert probes_wanted(bare) == {"damping", "capacities"} and probes_wanted(result.robot) == set(PROBES)


def test_an_output_reads_only_the_probe_results_it_names() -> None:
    """Each probe result has its runner, and one no output named is refused, not None: a batch model written with
    no capacities would still be valid (seeded fault: the batch model's entry without ``probes=("capacities",)``
    -> every build stops here with this error)."""
    assert tuple(probes.RUN) == PROBES
    with pytest.raises(LookupError, match="'capacities' was not run"):
        _ = Probed({"damping": {}}).capacities
    assert Probed({"damping": {"a": 1.0}}).damping == {"a": 1.0}
