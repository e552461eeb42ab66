"""MoveIt's collision matrix sampled in rounds, each leaving out the pairs the earlier ones settled: the same matrix
as one round of every sample, for less narrowphase."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest

from svhdesc.compiler.probes import collision_matrix
from svhdesc.compiler.probes.collision_matrix import ALWAYS_FRACTION, _settled
from tests.support import REPO


def test_a_pair_settles_once_no_remaining_sample_can_make_it_always() -> None:
    """1000 samples, 400 drawn: `Always` needs 950 touching; 350 touching + 600 left can still get there, 349 cannot
    (seeded faults: a rule without the samples left, or settling pairs never near, fail the asserts)."""
    samples, drawn = 1000, 400
    need = int(ALWAYS_FRACTION * samples) - (samples - drawn)
    touching = {(1, 2): need, (1, 3): need - 1, (2, 3): 0, (4, 5): drawn}
    near = {(1, 2), (1, 3), (2, 3), (4, 5)}
    assert _settled((touching, near), drawn, samples) == {(1, 3), (2, 3)}
    assert _settled((touching | {(6, 7): 0}, near), drawn, samples) == {(1, 3), (2, 3)}  # (6, 7) was never near
    assert _settled((touching, near), samples, samples) == near  # all drawn: each touched in fewer than 950


def test_rounds_give_the_matrix_of_one_round(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """svh_right, 600 samples: in rounds of 100 (later rounds leaving pairs out) and in one round, the same matrix
    (seeded fault: each round drawing from a new generator of the same seed -> the matrices differ)."""
    from svhdesc.compiler.decompose.cache import HullCache
    from svhdesc.compiler.decompose.source import HullSource
    from svhdesc.compiler.pipeline import steps
    from svhdesc.compiler.pipeline.timings import Timings
    from svhdesc.core.settings.config import load_config

    hulls = HullSource(HullCache(tmp_path / "hulls"))
    hulls.seed_from_outputs([REPO / "generated" / "svh_right"])
    config = load_config(REPO / "config" / "svhdesc.yaml")
    (compiled,) = steps.compile_variants(config, ["svh_right"], {}, hulls, Timings())
    left_out: list[int] = []
    real = collision_matrix._sample

    def counting(robot: Any, model: Any, *rest: Any) -> None:
        left_out.append(model.nexclude)
        real(robot, model, *rest)

    monkeypatch.setattr(collision_matrix, "_sample", counting)
    matrices = {}
    for rounds in (100, 600):
        monkeypatch.setattr(collision_matrix, "ROUND", rounds)
        matrices[rounds] = collision_matrix.collision_matrix(compiled.robot, compiled.assets, samples=600)
    assert list(matrices[100].items()) == list(matrices[600].items())
    assert len(left_out) == 7 and left_out[5] > left_out[0], left_out  # six rounds that left more out, then one
    assert "Never" in matrices[600].values()
