"""The import API, from the checkout and from an installed (non-editable) wheel."""

from __future__ import annotations

import subprocess
import sys
import venv
from pathlib import Path

from .support import REPO


def test_import_does_not_load_mujoco() -> None:
    code = "import sys, svhdesc; svhdesc.variants(); svhdesc.URDF_PATH; print('mujoco' in sys.modules)"
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True, cwd="/")
    assert result.stdout.strip() == "False"


def test_installed_wheel_ships_the_models(tmp_path: Path) -> None:
    wheels = tmp_path / "wheels"
    subprocess.run(
        [sys.executable, "-m", "pip", "wheel", "--no-deps", "-q", "-w", str(wheels), str(REPO)],
        check=True,
        capture_output=True,
    )
    env_dir = tmp_path / "venv"
    venv.create(env_dir, with_pip=True, system_site_packages=True)
    python = env_dir / "bin" / "python"
    wheel = next(wheels.glob("svhdesc-*.whl"))
    subprocess.run(
        [str(python), "-m", "pip", "install", "-q", "--no-deps", "--force-reinstall", str(wheel)],
        check=True,
        capture_output=True,
    )
    code = (
        "import svhdesc, mujoco\n"
        "assert 'site-packages' in svhdesc.__file__, svhdesc.__file__\n"
        "print(svhdesc.variants())\n"
        "m = svhdesc.get('ur5_svh_right')\n"
        "assert m.urdf_path.is_file() and m.mjcf_path.is_file() and m.scene_path.is_file()\n"
        "assert svhdesc.MJCF_PATH == m.mjcf_path\n"
        "model = svhdesc.load_mujoco('svh_left')\n"
        "print(model.nu, model.neq)\n"
        "mujoco.MjModel.from_xml_path(str(svhdesc.get('ur5_svh_right').scene_path))\n"
    )
    result = subprocess.run([str(python), "-c", code], capture_output=True, text=True, cwd=tmp_path)
    assert result.returncode == 0, result.stderr
    assert result.stdout.splitlines() == ["['svh_left', 'svh_right', 'ur5_svh_right']", "9 11"]
