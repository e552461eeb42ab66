"""Collision geometry: decomposition through the content cache, hull caps, convexity, primitives."""

from __future__ import annotations

import json
import re
import subprocess
from collections.abc import Callable
from pathlib import Path

import mujoco
import numpy as np
import pytest
import trimesh
import yaml
from lxml import etree

from svhdesc.compiler.decompose import LINK_CLASS_PARAMS
from svhdesc.compiler.decompose.cache import CacheWarning
from tests.support import REPO, VARIANTS, built, compiled_variant, exported, run_cli

GENERATED = REPO / "generated"


def cli(*args: str, cache: Path) -> subprocess.CompletedProcess[str]:
    return run_cli(*args, env={"SVHDESC_CACHE": str(cache)}, timeout=900)


def decomposition_counts(stderr: str) -> tuple[int, int, int]:
    match = re.search(r"decompositions: (\d+) run, (\d+) from the cache, (\d+) from committed", stderr)
    assert match, stderr
    return tuple(int(g) for g in match.groups())  # type: ignore[return-value]


def hand_config(tmp_path: Path, collision: dict) -> Path:
    path = tmp_path / "hand.yaml"
    path.write_text(
        yaml.safe_dump(
            {
                "extends": str(REPO / "config" / "svhdesc.yaml"),
                "collision": collision,
                "variants": {"hand": {"xacro": str(REPO / "xacro" / "svh_hand.urdf.xacro"), "args": {"side": "right"}}},
            }
        )
    )
    return path


def l_shaped_mini(project: Callable[..., Path], max_convex_hull: int) -> Path:
    """The mini robot with its finger's collision mesh an L of two boxes (CoACD cuts it in two in well under a
    second), decomposed with ``max_convex_hull``; its config."""
    root = project("mini")
    boxes = [trimesh.creation.box((0.02, 0.01, 0.04)), trimesh.creation.box((0.02, 0.03, 0.01))]
    boxes[1].apply_translation((0.0, 0.01, -0.015))
    trimesh.boolean.union(boxes).export(root / "l.stl")
    finger = root / "finger.xacro"
    finger.write_text(finger.read_text().replace('filename="cube.stl" scale="1 1 2"', 'filename="l.stl"'))
    return set_hull_cap(root / "mini.yaml", max_convex_hull)


def set_hull_cap(config: Path, max_convex_hull: int) -> Path:
    data = yaml.safe_load(config.read_text())
    params = {"max_convex_hull": max_convex_hull}
    data["collision"] = {"mode": "hull", "links": {"{hand}_p": {"mode": "decompose", "params": params}}}
    config.write_text(yaml.safe_dump(data, sort_keys=False))
    return config


def compile_hull(config: Path, cache: Path) -> tuple[tuple[int, int, int], list[bytes]]:
    """The config's robot compiled in this process (tests/support.py ``compiled_variant``; the outputs a build
    samples in MuJoCo are not made): the decompositions (run, from the cache, from committed outputs), as ``build
    --timings`` counts them, and the decomposed mesh's hulls."""
    compiled, hulls = compiled_variant(config, cache)
    counts = (hulls.counts["decomposed"], hulls.counts["cached"], hulls.counts["committed"])
    files = compiled.assets.files
    return counts, [files[name] for name in sorted(files) if name.startswith("l_hull_")]


def test_cache_hit_miss_and_corrupt_entry(tmp_path: Path, project: Callable[..., Path]) -> None:
    """Through the build's hull source, in process (``compile_hull``; the CLI's counts and --rebuild-collisions:
    test_rebuild_collisions_forces_decomposition), on the mini robot's L-shaped finger."""
    cache = tmp_path / "cache"
    config = l_shaped_mini(project, 3)
    counts, cold = compile_hull(config, cache)
    assert counts == (1, 0, 0)
    assert 1 < len(cold) <= 3
    # Warm: no decomposition, identical hulls.
    assert compile_hull(config, cache) == ((0, 1, 0), cold)
    # A parameter change misses.
    counts, capped = compile_hull(set_hull_cap(config, 1), cache)
    assert counts == (1, 0, 0)
    assert len(capped) == 1
    # A corrupt entry is detected and rebuilt, never used.
    entries = [
        p.parent
        for p in cache.rglob("entry.json")
        if json.loads(p.read_text())["meta"]["params"]["max_convex_hull"] == 1
    ]
    assert len(entries) == 1
    hull_file = sorted(entries[0].glob("hull_*.stl"))[0]
    hull_file.write_bytes(hull_file.read_bytes()[:100])
    with pytest.warns(CacheWarning, match="does not match its digest; decomposing again"):
        assert compile_hull(config, cache) == ((1, 0, 0), capped)


@pytest.mark.slow
def test_rebuild_collisions_forces_decomposition(tmp_path: Path, project: Callable[..., Path]) -> None:
    """Through the CLI's counts, on the mini robot with its finger's collision mesh decomposed (a build of the hand
    spent its time sampling the model, not decomposing). Seeded fault: --rebuild-collisions not forcing -> the
    second build's counts are (0, 1, 0)."""
    root = project("mini")
    config = root / "mini.yaml"
    config.write_text(config.read_text().replace("collision: {mode: hull}", "collision: {mode: decompose}"))
    args = ("build", "--config", str(config), "--out", str(tmp_path / "out"), "--timings")
    assert decomposition_counts(cli(*args, cache=tmp_path / "c").stderr) == (1, 0, 0)
    assert decomposition_counts(cli(*args, "--rebuild-collisions", cache=tmp_path / "c").stderr) == (1, 0, 0)


def hull_caps(variant: str) -> dict[str, int]:
    """Link -> max_convex_hull of its decomposition, as the config resolves it (classes, then per-link overrides)."""
    from svhdesc.compiler.pipeline.steps import plan_variant
    from svhdesc.compiler.pipeline.timings import Timings
    from svhdesc.core.settings.config import load_config

    selected = load_config(REPO / "config" / "svhdesc.yaml").select([variant])[0]
    jobs = plan_variant(selected, {}, None, Timings()).jobs
    return {link: params.max_convex_hull for link, _, params in jobs}


@pytest.mark.parametrize("variant", VARIANTS)
def test_every_collision_mesh_is_convex_and_within_its_cap(variant: str) -> None:
    mjcf = etree.parse(str(GENERATED / variant / f"{variant}.xml"))
    caps = {"palm": 8, "fingertip": 4, "phalanx": 4, "arm": 6}
    assert caps == {k: p.max_convex_hull for k, p in LINK_CLASS_PARAMS.items()}
    per_body: dict[str, int] = {}
    for geom in mjcf.iterfind(".//geom[@class='collision']"):
        body = geom.getparent().get("name")
        mesh = trimesh.load(GENERATED / variant / "assets" / f"{geom.get('mesh')}.obj")
        assert mesh.is_convex and mesh.is_watertight, geom.get("mesh")
        assert len(mesh.vertices) <= 64
        per_body[body] = per_body.get(body, 0) + 1
    caps_per_link = hull_caps(variant)
    for body, count in per_body.items():
        assert count <= caps_per_link.get(body, 1), body  # a link the config does not decompose has one hull
    assert max(per_body.values()) > 1  # really decomposed, not one hull each


@pytest.mark.slow
def test_primitive_collisions_compile_and_simulate(tmp_path: Path) -> None:
    config = hand_config(
        tmp_path, {"mode": "primitive", "primitive": "capsule", "links": {"{hand}_e1": {"primitive": "box"}}}
    )
    exported(config, "{robot}.urdf", "{robot}.xml", into=tmp_path / "out" / "hand")  # no sampled outputs
    model = mujoco.MjModel.from_xml_path(str(tmp_path / "out" / "hand" / "hand.xml"))
    kinds = {int(model.geom_type[g]) for g in range(model.ngeom) if model.geom_group[g] == 3}
    assert kinds == {int(mujoco.mjtGeom.mjGEOM_CAPSULE), int(mujoco.mjtGeom.mjGEOM_BOX)}
    data = mujoco.MjData(model)
    rng = np.random.default_rng(0)
    for step in range(1000):
        if step % 100 == 0:
            data.ctrl[:] = rng.uniform(model.actuator_ctrlrange[:, 0], model.actuator_ctrlrange[:, 1])
        mujoco.mj_step(model, data)
    assert not any(w.number for w in data.warning)
    urdf = etree.parse(str(tmp_path / "out" / "hand" / "hand.urdf"))
    assert urdf.find("link[@name='right_hand_e1']/collision/geometry/box") is not None


@pytest.mark.slow
def test_vendor_description_compiles_and_simulates_without_warnings(vendor_build: tuple[Path, object]) -> None:
    """The upstream meshes compile to hulls (one each, the index fingertip's through CoACD: tests/conftest.py
    VENDOR_COLLISION) and the models simulate and track their couplings."""
    out, _ = vendor_build
    for variant in ("svh_vendor_right", "svh_vendor_left", "ur5_svh_vendor_right"):
        check = run_cli("validate", variant, "--out", str(out), "--checks", "simulate,coupling_tracking,kinematics")
        assert check.returncode == 0, check.stdout + check.stderr
        hulls = [p.name for p in (out / variant / "assets").glob("*_hull*.obj")]
        pieces = [name for name in hulls if "_hull_" in name]
        assert len(pieces) > 1 and len({name.rsplit("_hull_", 1)[0] for name in pieces}) == 1, pieces
        assert len(hulls) - len(pieces) >= 20, hulls  # every other mesh: one hull


def test_built_outputs_are_the_committed_ones() -> None:
    """The session build used the cache or committed hulls and still reproduced generated/ exactly."""
    for variant in ("svh_right", "ur5_svh_right"):
        hulls = sorted((GENERATED / variant / "assets").glob("*_hull_*.obj"))
        assert len(hulls) > 23
        for path in hulls:
            assert (built() / variant / "assets" / path.name).read_bytes() == path.read_bytes()
