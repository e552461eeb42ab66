"""The import API and the CLI from the checkout, from another checkout, and from an installed (non-editable) wheel
in a virtual environment that inherits nothing from this interpreter."""

from __future__ import annotations

import hashlib
import subprocess
import sys
import venv
from collections.abc import Callable
from pathlib import Path

import pytest

from tests.support import REPO, VARIANTS, run_cli


def test_import_does_not_load_mujoco() -> None:
    code = "import sys, svhdesc; svhdesc.variants(); svhdesc.URDF_PATH; print('mujoco' in sys.modules)"
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True, cwd="/")
    assert result.stdout.strip() == "False"


def _digest(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


@pytest.mark.slow
def test_build_inside_another_checkout_builds_that_checkout(project: Callable[..., Path], session_build: Path) -> None:
    """The clone's config is the one built, into the clone. Its change shows in the URDF, not in the MJCF, so the
    results the build samples in MuJoCo are the session build's (tests/conftest.py session_build: the run's cache)
    and not sampled again."""
    clone = project(parts=("config", "xacro", "meshes", "generated", "svhdesc", "pyproject.toml"), name="clone")
    config = clone / "config" / "svhdesc.yaml"
    config.write_text(config.read_text().replace("interface: position ", "interface: effort ", 1))
    ours = REPO / "generated" / "svh_right" / "svh_right.urdf"
    before = _digest(ours)
    result = run_cli("build", "svh_right", cwd=clone / "meshes")  # anywhere below the checkout's root
    assert result.returncode == 0, result.stderr
    assert f"built {clone / 'generated' / 'svh_right'}" in result.stdout
    effort = "hardware_interface/EffortJointInterface"
    assert effort in (clone / "generated" / "svh_right" / "svh_right.urdf").read_text()
    assert effort not in ours.read_text() and _digest(ours) == before


@pytest.mark.slow
def test_build_with_a_users_config_writes_beside_it(tmp_path: Path) -> None:
    config = tmp_path / "mine" / "robot.yaml"
    config.parent.mkdir()
    config.write_text(
        f"extends: {REPO / 'config' / 'svhdesc.yaml'}\n"
        f"variants:\n  my_hand:\n    xacro: {REPO / 'xacro' / 'svh_hand.urdf.xacro'}\n    args: {{side: right}}\n"
    )
    result = run_cli("build", "--config", str(config), cwd=tmp_path)
    assert result.returncode == 0, result.stderr
    built = tmp_path / "mine" / "generated" / "my_hand"
    assert (built / "my_hand.urdf").is_file() and (built / "package.xml").is_file()
    assert not (REPO / "generated" / "my_hand").exists()


@pytest.mark.slow
def test_installed_wheel_works_anywhere(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    # The wheel's own venv must import the wheel: a PYTHONPATH naming a checkout would win over its site-packages.
    monkeypatch.delenv("PYTHONPATH", raising=False)
    wheels = tmp_path / "wheels"
    subprocess.run(
        [sys.executable, "-m", "pip", "wheel", "--no-deps", "-q", "-w", str(wheels), str(REPO)],
        check=True,
        capture_output=True,
    )
    env_dir = tmp_path / "venv"
    # No pip of its own (ensurepip costs ~9 s): this pip installs into it (--python), without compiling every module
    # of the dependencies to bytecode first (~60 s of CPU); Python compiles what it imports, as after any install.
    venv.create(env_dir, with_pip=False, system_site_packages=False)
    python = str(env_dir / "bin" / "python")
    wheel = next(wheels.glob("svhdesc-*.whl"))
    constraints = str(REPO / "constraints.txt")
    install = subprocess.run(
        [sys.executable, "-m", "pip", "--python", python, "install", "-q", "--no-compile", "-c", constraints]
        + [f"{wheel}[sim,validate]"],
        capture_output=True,
        text=True,
    )
    assert install.returncode == 0, install.stderr[-3000:]
    work = tmp_path / "elsewhere"
    work.mkdir()
    code = (
        "import svhdesc, mujoco\n"
        "assert 'site-packages' in svhdesc.__file__, svhdesc.__file__\n"
        "print(svhdesc.variants())\n"
        "m = svhdesc.get('ur5_svh_right')\n"
        "assert m.urdf_path.is_file() and m.mjcf_path.is_file() and m.scene_path.is_file()\n"
        "assert svhdesc.MJCF_PATH == m.mjcf_path and m.package_name == 'ur5_svh_right'\n"
        "assert m.absolute_urdf_path().is_file()\n"
        "model = svhdesc.load_mujoco('svh_left')\n"
        "print(model.nu, model.neq)\n"
        "mujoco.MjModel.from_xml_path(str(svhdesc.get('ur5_svh_right').scene_path))\n"
    )
    result = subprocess.run([python, "-c", code], capture_output=True, text=True, cwd=work)
    assert result.returncode == 0, result.stderr
    assert result.stdout.splitlines() == [str(sorted(VARIANTS)), "9 11"]

    listed = run_cli("list", cwd=work, python=python)
    assert listed.returncode == 0, listed.stderr
    assert [line.split("\t")[0] for line in listed.stdout.splitlines()] == list(VARIANTS)
    checked = run_cli("validate", "svh_left", "--checks", "simulate,mass,yourdfpy,limits", cwd=work, python=python)
    assert checked.returncode == 0, checked.stdout + checked.stderr
    rendered = run_cli(
        "render", "svh_left", "--out", str(work / "left.png"), "--size", "64x48", cwd=work, python=python
    )
    assert rendered.returncode == 0, rendered.stderr
    assert (work / "left.png").read_bytes().startswith(b"\x89PNG")
    # The compiler is an extra of its own; the shipped sources are never an output folder.
    info = run_cli("info", "svh_left", cwd=work, python=python)
    assert info.returncode == 2 and info.stderr.strip().endswith("pip install 'svhdesc[build]'"), info.stderr
    where = subprocess.run([python, "-c", "import svhdesc; print(svhdesc.__file__)"], capture_output=True, text=True)
    site = Path(where.stdout.strip()).parent
    before = sorted(p.relative_to(site) for p in site.rglob("*") if "__pycache__" not in p.parts)
    build = run_cli("build", "svh_left", cwd=work, python=python)
    assert build.returncode == 2, build.stderr
    assert "error:" in build.stderr and "Traceback" not in build.stderr
    assert sorted(p.relative_to(site) for p in site.rglob("*") if "__pycache__" not in p.parts) == before
