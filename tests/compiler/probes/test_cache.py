"""Sampled results (batch capacities, MoveIt's collision matrix) are remembered by content: a hit gives the same
result without sampling, any changed input is a miss, and a broken entry is sampled again."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from svhdesc.compiler.export.batch import Capacities
from svhdesc.compiler.probes import batch_capacities, collision_matrix
from svhdesc.compiler.probes.cache import content_key, remembered
from tests.support import REPO, TESTS, VARIANTS

VARIANT = REPO / "generated" / "svh_right"


def test_key_covers_every_part_and_every_asset() -> None:
    base = content_key((b"model", b"scene"), {"a.stl": b"1", "b.stl": b"2"})
    assert base == content_key((b"model", b"scene"), {"b.stl": b"2", "a.stl": b"1"})  # order of assets is no input
    assert base != content_key((b"model!", b"scene"), {"a.stl": b"1", "b.stl": b"2"})
    assert base != content_key((b"scene", b"model"), {"a.stl": b"1", "b.stl": b"2"})
    assert base != content_key((b"model", b"scene"), {"a.stl": b"1", "b.stl": b"3"})
    assert base != content_key((b"model", b"scene"), {"a.stl": b"1", "c.stl": b"2"})


def test_hit_miss_and_broken_entry(tmp_path: Path) -> None:
    calls: list[int] = []

    def compute() -> dict[str, int]:
        calls.append(1)
        return {"n": len(calls)}

    def ask(key: str) -> dict[str, int]:
        return remembered(tmp_path, key, compute, dict, dict)

    assert ask("k1") == {"n": 1} and ask("k1") == {"n": 1} and len(calls) == 1  # hit: not computed again
    assert ask("k2") == {"n": 2}  # another key: computed
    (tmp_path / "k1.json").write_text("{not json")
    assert ask("k1") == {"n": 3} and ask("k1") == {"n": 3}  # broken: computed again and rewritten
    assert not list(tmp_path.glob("*.tmp"))
    unwritable = tmp_path / "file"
    unwritable.write_text("")
    assert remembered(unwritable / "cache", "k", compute, dict, dict) == {"n": 4}  # no cache: still a result


def test_a_forged_or_edited_entry_is_computed_again(tmp_path: Path) -> None:
    """Another key's entry copied into place, or an edited value, is one warning and never used (seeded fault: the
    key or digest comparison removed from remembered._read, and the forged value comes back)."""
    values = iter(range(100))

    def ask(key: str) -> dict[str, int]:
        return remembered(tmp_path, key, lambda: {"n": next(values)}, dict, dict)

    assert ask("k1") == {"n": 0} and ask("k2") == {"n": 1}
    (tmp_path / "k1.json").write_bytes((tmp_path / "k2.json").read_bytes())
    with pytest.warns(UserWarning, match="another key") as caught:
        assert ask("k1") == {"n": 2}
    assert len(caught) == 1
    entry = tmp_path / "k2.json"
    entry.write_text(entry.read_text().replace('"n": 1', '"n": 7'))
    with pytest.warns(UserWarning, match="does not match its digest"):
        assert ask("k2") == {"n": 3}
    assert ask("k1") == {"n": 2} and ask("k2") == {"n": 3}  # healed: hits again


def test_batch_capacities_are_sampled_once_per_content(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("SVHDESC_CACHE", str(tmp_path))
    sampled: list[bytes] = []

    def counting(scene: bytes, name: str, model: bytes, assets: Path) -> Capacities:
        sampled.append(model)  # the caching is under test, not the sampling: a made-up worst case
        return Capacities.from_worst_case(10 + len(sampled), 20, 30)

    monkeypatch.setattr(batch_capacities, "sample_capacities", counting)
    scene = (VARIANT / "scene_batch.xml").read_bytes()
    model = (VARIANT / "svh_right_batch.xml").read_bytes()
    assets = VARIANT / "assets"
    first = batch_capacities.cached_capacities(scene, "svh_right_batch.xml", model, assets)
    assert batch_capacities.cached_capacities(scene, "svh_right_batch.xml", model, assets) == first
    assert len(sampled) == 1
    # One more line in the model: a different model, sampled again.
    other = batch_capacities.cached_capacities(scene, "svh_right_batch.xml", model + b"\n", assets)
    assert len(sampled) == 2 and other != first


def test_collision_matrix_entry_is_the_computed_matrix(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """The cached matrix is the computed one, pair order included (the SRDF writes pairs in this order); a changed
    robot is computed again."""
    from dataclasses import replace

    from svhdesc.compiler.decompose.cache import HullCache
    from svhdesc.compiler.decompose.source import HullSource
    from svhdesc.compiler.pipeline import steps
    from svhdesc.compiler.pipeline.timings import Timings
    from svhdesc.core.settings.config import load_config

    monkeypatch.setenv("SVHDESC_CACHE", str(tmp_path / "cache"))
    hulls = HullSource(HullCache(tmp_path / "hulls"))
    (compiled,) = steps.compile_variants(load_config(TESTS / "data" / "mini" / "mini.yaml"), [], {}, hulls, Timings())
    computed: list[dict[tuple[str, str], str]] = []
    real = collision_matrix.collision_matrix
    monkeypatch.setattr(collision_matrix, "collision_matrix", lambda *a: computed.append(real(*a)) or computed[-1])
    fresh = collision_matrix.cached_collision_matrix(compiled.robot, compiled.assets)
    again = collision_matrix.cached_collision_matrix(compiled.robot, compiled.assets)
    assert len(computed) == 1 and fresh and list(again.items()) == list(fresh.items())
    moved = replace(compiled.robot, joints=tuple(replace(j, upper=j.upper * 0.5) for j in compiled.robot.joints))
    collision_matrix.cached_collision_matrix(moved, compiled.assets)
    assert len(computed) == 2


def test_a_result_rewritten_with_its_digest_is_sampled_again_while_recomputing(tmp_path: Path) -> None:
    """An entry whose value was rewritten together with its digest passes every check of an entry: served to a
    build, never to a check that trusts no cache (``recomputing``, which build --check sets), which samples again and
    heals the entry (seeded fault: remembered reading the entry whatever RECOMPUTE says)."""
    import hashlib
    import json

    from svhdesc.compiler.probes.cache import recomputing

    calls: list[int] = []

    def compute() -> dict[str, int]:
        calls.append(1)
        return {"njmax": 7}

    def use() -> dict[str, int]:
        return remembered(tmp_path, "k" * 64, compute, lambda v: v, lambda v: v)

    assert use() == {"njmax": 7}
    entry = tmp_path / f"{'k' * 64}.json"
    forged = {"njmax": 1}
    digest = hashlib.sha256(json.dumps(forged, sort_keys=True).encode()).hexdigest()
    entry.write_text(json.dumps({"key": "k" * 64, "sha256": digest, "value": forged}))
    assert use() == forged and len(calls) == 1  # the documented trust
    with recomputing():
        assert use() == {"njmax": 7} and len(calls) == 2
    assert use() == {"njmax": 7} and len(calls) == 2  # healed


def test_the_trial_run_is_stepped_once_per_model(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """The build's trial run (validate's 10 s simulate run) is remembered by content: a second build of the same
    model reads its result, a passing run's included (seeded fault: a passing run stored as null, which the cache
    reads as no entry: stepped at every build)."""
    from svhdesc.compiler.decompose.cache import HullCache
    from svhdesc.compiler.decompose.source import HullSource
    from svhdesc.compiler.pipeline import steps
    from svhdesc.compiler.pipeline.timings import Timings
    from svhdesc.compiler.probes import stability
    from svhdesc.core.settings.config import load_config

    monkeypatch.setenv("SVHDESC_CACHE", str(tmp_path / "cache"))
    stepped: list[object] = []
    real = stability.diverges
    monkeypatch.setattr(stability, "diverges", lambda model: stepped.append(real(model)) or stepped[-1])
    for _ in range(2):
        hulls = HullSource(HullCache(tmp_path / "hulls"))
        list(steps.compile_variants(load_config(TESTS / "data" / "mini" / "mini.yaml"), [], {}, hulls, Timings()))
    assert stepped == [None]


# What each sampling function computes: its cache folder's name, the kind in a manifest's ``sampled``.
KINDS = {
    "diverges": "trial_run",
    "collision_matrix": "collision_matrix",
    "sample_capacities": "capacities",
    "stopped_poses": "keyframe_poses",
}


def _counting_probes(monkeypatch: pytest.MonkeyPatch) -> list[str]:
    """The kinds of the results sampled from now on, one entry each time one is computed instead of read."""
    from svhdesc.compiler.probes import keyframe_contacts, stability

    computed: list[str] = []
    for module in (stability, collision_matrix, batch_capacities, keyframe_contacts):
        for name in KINDS.keys() & vars(module).keys():
            real = getattr(module, name)
            monkeypatch.setattr(module, name, lambda *a, _f=real, _k=KINDS[name]: computed.append(_k) or _f(*a))
    return computed


def test_a_build_reads_the_sampled_results_of_its_committed_outputs(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A built variant's manifest holds the results its build sampled; a later build into the same folder with an
    empty cache (a fresh clone's) reads them there and samples nothing, writing the same manifest, while a build
    that trusts nothing (``recomputing``, build --check's) samples again (seeded faults: remembered ignoring the
    seeds, and every probe is computed again; remembered reading them while recomputing, and none is)."""
    from svhdesc.compiler.decompose.cache import HullCache
    from svhdesc.compiler.decompose.source import HullSource
    from svhdesc.compiler.pipeline import builder
    from svhdesc.compiler.probes.cache import recomputing
    from svhdesc.core.settings.config import load_config

    config, out = load_config(TESTS / "data" / "mini" / "mini.yaml"), tmp_path / "out"
    (variant,) = config.variants
    computed = _counting_probes(monkeypatch)

    def build(cache: str) -> dict[str, dict[str, object]]:
        monkeypatch.setenv("SVHDESC_CACHE", str(tmp_path / cache))
        builder.build(config, [], out, {}, HullSource(HullCache(tmp_path / cache / "hulls")))
        return json.loads((out / variant / "manifest.json").read_text())

    first = build("one")
    assert sorted(computed) == sorted(KINDS.values())  # the mini robot samples each kind once
    assert {kind: len(entries) for kind, entries in first["sampled"].items()} == dict.fromkeys(KINDS.values(), 1)
    computed.clear()
    assert build("two") == first and computed == []  # an empty cache: each read from the committed manifest
    with recomputing():
        assert build("three") == first
    assert sorted(computed) == sorted(KINDS.values())


def test_a_committed_result_that_does_not_decode_is_computed_again(tmp_path: Path) -> None:
    """A manifest's result that its probe cannot read (hand-edited) is one warning naming it and computed again
    (seeded fault: the decode error escaping remembered: the build fails)."""
    from svhdesc.compiler.probes.cache import seeded

    with seeded({"capacities": {"k" * 64: "not a mapping"}}), pytest.warns(UserWarning, match="committed capacities"):
        result = remembered(tmp_path / "capacities", "k" * 64, lambda: {"n": 1}, dict, lambda v: dict(v))
    assert result == {"n": 1}


def test_each_shipped_manifest_holds_its_own_sampled_results() -> None:
    """Every shipped variant's manifest holds one result of each kind, and no variant another's: the recording is
    per variant, so that building one variant alone writes the manifest a build of all writes (seeded fault: one
    recording for the whole build: svh_left's manifest holds svh_right's results too)."""
    manifests = {v: json.loads((REPO / "generated" / v / "manifest.json").read_text()) for v in VARIANTS}
    for manifest in manifests.values():
        assert {kind: len(entries) for kind, entries in manifest["sampled"].items()} == dict.fromkeys(KINDS.values(), 1)
    keys = [key for manifest in manifests.values() for entries in manifest["sampled"].values() for key in entries]
    assert len(keys) == len(set(keys)) == len(KINDS) * len(manifests)
