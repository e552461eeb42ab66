"""The committed ROS 2 package of ur5_svh_right (generated/ur5_svh_right/ros2) configured and installed by CMake with
the real ament_cmake of the Jazzy wheels, then the installed URDF xacro expanded by xacro with ``$(find)`` resolved
through the installed ament index: the share directory holds what the package's paths and package:// URIs name.

Runs in .venv-ros2 (ament_cmake and ament_index_python come from its wheels); skips elsewhere.
Seeded fault: without ``PATTERN "package.xml" EXCLUDE`` in CMakeLists.txt the ROS 1 package.xml (catkin) is the
installed one and test_installed_share_directory_is_the_variant_folder fails.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
from lxml import etree

pytest.importorskip("ament_index_python")
if shutil.which("cmake") is None:
    pytest.skip("cmake missing", allow_module_level=True)

from tests.support import REPO  # noqa: E402

VARIANT = "ur5_svh_right"
pytestmark = pytest.mark.slow


@pytest.fixture(scope="module")
def installed(tmp_path_factory: pytest.TempPathFactory) -> Path:
    work = tmp_path_factory.mktemp("ament")
    build, prefix = work / "build", work / "install"
    configure = [
        "cmake",
        "-S",
        str(REPO / "generated" / VARIANT / "ros2"),
        "-B",
        str(build),
        f"-DCMAKE_INSTALL_PREFIX={prefix}",
        f"-DCMAKE_PREFIX_PATH={sys.prefix}",
        f"-DPython3_EXECUTABLE={sys.executable}",
    ]
    env = {**os.environ, "PATH": f"{Path(sys.executable).parent}:{os.environ['PATH']}"}
    for command in (configure, ["cmake", "--install", str(build)]):
        result = subprocess.run(command, capture_output=True, text=True, env=env)
        assert result.returncode == 0, result.stdout + result.stderr
    return prefix


def test_installed_share_directory_is_the_variant_folder(installed: Path) -> None:
    share = installed / "share" / VARIANT
    assert (installed / "share" / "ament_index" / "resource_index" / "packages" / VARIANT).is_file()
    assert "<buildtool_depend>ament_cmake</buildtool_depend>" in (share / "package.xml").read_text()
    for name in (f"{VARIANT}.urdf", "assets", "ros2/config/ros2_controllers.yaml", "ros2/mujoco/scene.xml"):
        assert (share / name).exists(), name


def test_installed_xacro_resolves_find_and_package_uris(installed: Path) -> None:
    share = installed / "share" / VARIANT
    env = {**os.environ, "AMENT_PREFIX_PATH": str(installed)}
    code = (
        "import sys, xacro; "
        "print(xacro.process_file(sys.argv[1], mappings={'hardware': 'gazebo'}).toxml())"  # no controllers:= given
    )
    source = share / "ros2" / "urdf" / f"{VARIANT}.urdf.xacro"
    result = subprocess.run([sys.executable, "-c", code, str(source)], capture_output=True, text=True, env=env)
    assert result.returncode == 0, result.stderr
    urdf = etree.fromstring(result.stdout.encode())
    parameters = urdf.findtext("gazebo/plugin[@filename='gz_ros2_control-system']/parameters")
    assert Path(parameters) == share / "ros2" / "config" / "ros2_controllers.yaml" and Path(parameters).is_file()
    meshes = {m.get("filename") for m in urdf.iter("mesh")}
    prefix = f"package://{VARIANT}/"
    assert meshes and all(m.startswith(prefix) and (share / m[len(prefix) :]).is_file() for m in meshes)
