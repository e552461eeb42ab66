"""Session-wide test settings and the shared fixtures.

- The Warp kernel cache; the run's folder with its hull cache (never the user's) and its one session build
  (`session_build`, tests/support.py `built()`), shared by pytest-xdist's workers and started in the background as
  soon as collection shows that a test needs it.
- The markers, set here by path so that a moved or new module cannot miss them: `ros` for every module under
  tests/ros and every module that starts a master (it imports tests/rosmaster.py); `slow` for those and the modules in
  SLOW. `pytest -m "not slow"` is the quick set for development; the README's command and CI run everything.
- xdist groups (`--dist loadgroup`, the default in pyproject.toml): the tests of a module with a module-scoped
  fixture (a ROS master, a planner, a build) run on one worker, so that the fixture is set up once and its tests
  run in the order they are written; the users of `vendor_build` share one group too.
- `vendor_build`, `project` (a copy of a project's sources to break), `session_build`.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import tempfile
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest
import yaml

# Bytecode is cached, as Python does by default, whatever PYTHONDONTWRITEBYTECODE says (container images often set
# it): else each xdist worker rewrites every test module's asserts anew (4-5 s of collection) and each of the suite's
# hundreds of CLI subprocesses compiles svhdesc again. The caches are __pycache__/ folders, which git ignores.
sys.dont_write_bytecode = False
os.environ.pop("PYTHONDONTWRITEBYTECODE", None)

from svhdesc.paths import user_cache  # noqa: E402

REPO = Path(__file__).resolve().parents[1]
TESTS = REPO / "tests"
# MuJoCo Warp compiles its kernels once (about 45 s of CPU) into the user's cache, beside the loaders' URDFs, so that
# a clean clone (CI's) finds them; CLI subprocesses inherit the path. Kernels are keyed by their source and version.
os.environ.setdefault("WARP_CACHE_PATH", str(user_cache("warp")))
# One folder for the whole run, made by the controller (or the only process) and inherited by xdist's workers: the
# decomposition cache (never the user's) and the session build (tests/support.py built()).
OWN_RUN = "SVHDESC_TEST_RUN" not in os.environ
if OWN_RUN:
    os.environ["SVHDESC_TEST_RUN"] = tempfile.mkdtemp(prefix="svhdesc-test-run-")
    os.environ.setdefault("SVHDESC_CACHE", str(Path(os.environ["SVHDESC_TEST_RUN"]) / "hulls"))


def pytest_unconfigure(config: pytest.Config) -> None:
    if OWN_RUN and not hasattr(config, "workerinput"):  # the controller (or a run without xdist) made it
        from .support import stop_build

        stop_build(Path(os.environ["SVHDESC_TEST_RUN"]))
        shutil.rmtree(os.environ["SVHDESC_TEST_RUN"], ignore_errors=True)


# The session build decomposes every shipped collision mesh (tests/support.py built(): the run's `build --check`).
# Started in the background once the run is known to need it, it overlaps the tests that come first instead of
# keeping a worker waiting on built()'s lock for it.
def _needs_session_build(item: pytest.Item) -> bool:
    import tests.support

    module = getattr(item, "module", None)
    uses = {getattr(module, name, None) for name in ("built", "model_files")} if module is not None else set()
    return "session_build" in getattr(item, "fixturenames", ()) or bool(
        uses & {tests.support.built, tests.support.model_files}
    )


def pytest_collection_finish(session: pytest.Session) -> None:
    from .support import start_build

    users = [item for item in session.items if _needs_session_build(item)]
    if users:
        # From the sources alone when a slow test uses it (the guard that generated/ is current among them).
        fresh = any(item.get_closest_marker("slow") for item in users)
        start_build(Path(os.environ["SVHDESC_TEST_RUN"]), fresh)


# Modules (paths under tests/) whose tests take tens of seconds each: engines, grasps held for seconds, Warp, full
# validate runs, planning end to end, builds in subprocesses. ROS modules are slow as well, wherever they are.
SLOW = {
    "batch/test_env.py",
    "compare/test_compare.py",
    "loaders/test_mujoco3.py",
    "loaders/test_newton.py",
    "plan/test_plan.py",
    "validate/test_fidelity.py",
    "validate/test_grasps.py",
    "wireloop/test_wireloop.py",
}
if missing := sorted(p for p in SLOW if not (TESTS / p).is_file()):  # a moved module must not lose its marker
    raise pytest.UsageError(f"tests/conftest.py SLOW names modules that do not exist: {missing}")


def _starts_a_master(module: object) -> bool:
    import tests.rosmaster

    return any(
        value is tests.rosmaster or getattr(value, "__module__", None) == "tests.rosmaster"
        for value in vars(module).values()
    )


def _module_fixture_group(item: pytest.Item) -> str | None:
    """The module's id if the test uses a module-scoped fixture (pytest's fixture info has no public accessor)."""
    definitions = getattr(item, "_fixtureinfo", None)
    for defs in definitions.name2fixturedefs.values() if definitions else ():
        if any(d.scope == "module" for d in defs):
            return item.nodeid.split("::", 1)[0]
    return None


@pytest.hookimpl(tryfirst=True)  # before xdist reads the groups
def pytest_collection_modifyitems(items: list[pytest.Item]) -> None:
    for item in items:
        path = Path(str(item.path)).resolve()
        relative = path.relative_to(TESTS).as_posix() if path.is_relative_to(TESTS) else ""
        module = getattr(item, "module", None)
        ros = relative.startswith("ros/") or (module is not None and _starts_a_master(module))
        if ros:
            item.add_marker(pytest.mark.ros)
        if ros or relative in SLOW:
            item.add_marker(pytest.mark.slow)
        if item.get_closest_marker("xdist_group") is None:
            if "vendor_build" in getattr(item, "fixturenames", ()):
                item.add_marker(pytest.mark.xdist_group("vendor_build"))
            elif "validated" in getattr(item, "fixturenames", ()):
                # One group per variant: the three full validate runs spread over the workers, each run once.
                variant = getattr(item, "callspec", None) and item.callspec.params.get("variant")
                item.add_marker(pytest.mark.xdist_group(f"validated-{variant or 'svh_right'}"))
            elif group := _module_fixture_group(item):
                item.add_marker(pytest.mark.xdist_group(group))


@pytest.fixture(scope="session")
def session_build() -> Path:
    """A fresh build of every variant of config/svhdesc.yaml, one per run (tests/support.py built())."""
    from .support import built

    return built()


@pytest.fixture(scope="session")
def validated(tmp_path_factory: pytest.TempPathFactory) -> Callable[[str], tuple[Any, dict[str, Any], Path]]:
    """``svhdesc validate VARIANT --json --plots`` of a shipped variant, run once per run and variant (its users share
    an xdist group): (the CLI's result, its checks by name, the plots folder). The full run's checks are the ones
    the fidelity and grasp tests assert on, so they read them here instead of running them again."""
    from .support import run_cli

    runs: dict[str, tuple[Any, dict[str, Any], Path]] = {}

    def run(variant: str) -> tuple[Any, dict[str, Any], Path]:
        if variant not in runs:
            folder = tmp_path_factory.mktemp(f"validated-{variant}")
            report, plots = folder / "report.json", folder / "plots"
            result = run_cli("validate", variant, "--json", str(report), "--plots", str(plots), in_process=True)
            checks = {c["name"]: c for c in json.loads(report.read_text())["variants"][0]["checks"]}
            runs[variant] = (result, checks, plots)
        return runs[variant]

    return run


# The vendor build is about compiling the upstream inputs (their xacro, meshes and limits) with this project's spec,
# not about decomposing them: every link gets one hull but the index fingertip, whose upstream mesh still goes
# through CoACD (the decomposition itself is covered by tests/compiler/decompose). Full CoACD on every upstream
# mesh cost ~3.5 minutes of a run's critical path.
VENDOR_COLLISION = {
    "mode": "hull",
    "links": {"{hand}_t": {"mode": "decompose", "params": {"threshold": 0.05, "max_convex_hull": 4}}},
}


@pytest.fixture(scope="session")
def vendor_build(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, subprocess.CompletedProcess[str]]:
    """config/vendor.yaml's three variants built from ../shared/vendor: (out, the build's result)."""
    from .support import VENDOR_SVH, VENDOR_UR, run_cli

    if not VENDOR_SVH.is_dir():
        pytest.skip("../shared/vendor is not beside this checkout")
    out = tmp_path_factory.mktemp("vendor")
    # Its variants as they are (a config does not inherit its base's variants), their paths made absolute.
    vendor = REPO / "config" / "vendor.yaml"
    variants = yaml.safe_load(vendor.read_text())["variants"]
    for variant in variants.values():
        variant["xacro"] = str((vendor.parent / variant["xacro"]).resolve())
    config = tmp_path_factory.mktemp("vendor-config") / "vendor.yaml"
    config.write_text(
        yaml.safe_dump({"extends": str(vendor), "collision": VENDOR_COLLISION, "variants": variants}, sort_keys=False)
    )
    packages = ("--package", f"schunk_svh_driver={VENDOR_SVH}", "--package", f"ur_description={VENDOR_UR}")
    result = run_cli("build", "--config", str(config), "--out", str(out), *packages)
    assert result.returncode == 0, result.stderr
    return out, result


PROJECT_PARTS = ("config", "xacro", "meshes")


@pytest.fixture
def project(tmp_path: Path) -> Callable[..., Path]:
    """Copies of a project's sources, to break in a test; each call makes one under tmp_path:

    - ``project()``: this project's sources (config, xacro, meshes), its config naming the copy as package
      ``svhdesc``, so that a build reads the copy's files;
    - ``project(parts=(..., "svhdesc", "pyproject.toml"))``: a whole other checkout (with pyproject.toml it finds
      its own root, and its config is left as it is);
    - ``project("mini")``: the two-joint robot of tests/data/mini (its config is mini.yaml).
    """

    def copy(source: str = "svh", parts: tuple[str, ...] = PROJECT_PARTS, name: str | None = None) -> Path:
        root = tmp_path / (name or source)
        if source == "mini":
            shutil.copytree(TESTS / "data" / "mini", root)
            return root
        root.mkdir()
        for part in parts:
            if (REPO / part).is_dir():
                shutil.copytree(REPO / part, root / part, ignore=shutil.ignore_patterns("__pycache__"))
            else:
                shutil.copy(REPO / part, root / part)
        if "pyproject.toml" not in parts:
            config = root / "config" / "svhdesc.yaml"
            data = yaml.safe_load(config.read_text())
            data["packages"] = {"svhdesc": ".."}
            config.write_text(yaml.safe_dump(data, sort_keys=False))
        return root

    return copy
