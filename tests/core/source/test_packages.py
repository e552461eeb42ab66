"""Where package://NAME and $(find NAME) lead from a file in a package's own tree (validate PATH, init)."""

from __future__ import annotations

from pathlib import Path

from svhdesc.core.source.packages import find_beside

REPO = Path(__file__).resolve().parents[3]


def _package(folder: Path, name: str) -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "package.xml").write_text(f"<package format='3'><name>{name}</name></package>")
    return folder


def test_the_outer_of_two_nested_packages_of_one_name_wins(tmp_path: Path) -> None:
    # svhdesc's generated/<variant>/ros2 is a ROS 2 package that installs its parent, the ROS 1 package of the same
    # name, as its share: a crawl from the workspace (rospack, colcon) meets the outer package.xml first.
    outer = _package(tmp_path / "robot", "robot")
    _package(outer / "ros2", "robot")
    source = outer / "ros2" / "urdf" / "robot.urdf.xacro"
    source.parent.mkdir(parents=True)
    assert find_beside("robot", source) == outer.resolve()


def test_a_package_named_otherwise_than_its_folder_and_a_sibling_folder(tmp_path: Path) -> None:
    own = _package(tmp_path / "src" / "checkout", "arm_description")
    (tmp_path / "src" / "gripper").mkdir()
    source = own / "urdf" / "arm.urdf"
    assert find_beside("arm_description", source) == own.resolve()
    assert find_beside("gripper", source) == (tmp_path / "src" / "gripper").resolve()
    assert find_beside("elsewhere", source) is None


def test_svhdescs_own_ros2_xacro_resolves_its_meshes_and_config_in_the_source_tree() -> None:
    variant = REPO / "generated" / "svh_right"
    found = find_beside("svh_right", variant / "ros2" / "urdf" / "svh_right.urdf.xacro")
    assert found == variant
    assert (found / "assets").is_dir() and (found / "ros2" / "config" / "ros2_controllers.yaml").is_file()
