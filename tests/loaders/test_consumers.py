"""The generated models in the tools people load them into: ROS (robot_state_publisher, RViz), sdformat, and tools
without ROS through absolute mesh paths."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest
from lxml import etree

import svhdesc
from tests.rosmaster import free_port
from tests.support import REPO, TESTS, run_cli

ROSPY = Path("/usr/lib/python3/dist-packages/rospy")
DEBIAN_PYTHON = "/usr/bin/python3"
needs_ros = pytest.mark.skipif(
    not ROSPY.is_dir(), reason="Debian's ROS 1 is not installed (bash tools/install.sh test)"
)


def free_display() -> str:
    number = 90 + os.getpid() % 400
    while Path(f"/tmp/.X11-unix/X{number}").exists() or Path(f"/tmp/.X{number}-lock").exists():
        number += 1
    return f":{number}"


def private_network(command: list[str]) -> list[str]:
    """Run in a network namespace of its own (loopback only) where we may make one; ROS binds 127.0.0.1 anyway."""
    tools = shutil.which("unshare") and shutil.which("ip")
    probe = subprocess.run(["unshare", "-n", "true"], capture_output=True) if tools else None
    if probe is None or probe.returncode != 0:
        return command
    return ["unshare", "-n", "sh", "-c", 'ip link set lo up && exec "$@"', "sh", *command]


def read_ppm(path: Path) -> np.ndarray:
    magic, size, maxval, pixels = path.read_bytes().split(b"\n", 3)
    assert magic == b"P6"
    width, height = (int(v) for v in size.split())
    dtype = ">u2" if int(maxval) > 255 else "u1"
    image = np.frombuffer(pixels, dtype)[: width * height * 3].reshape(height, width, 3)
    return (image.astype(float) * 255.0 / int(maxval)).astype(np.uint8)


@needs_ros
def test_ros_tools_resolve_every_mesh_and_publish_every_frame(tmp_path: Path) -> None:
    model = svhdesc.get("ur5_svh_right")
    script = TESTS / "ros" / "consumers.py"
    command = [DEBIAN_PYTHON, str(script), str(model.directory), str(free_port()), free_display(), str(tmp_path)]
    result = subprocess.run(private_network(command), capture_output=True, text=True, timeout=240, cwd=tmp_path)
    assert result.returncode == 0, result.stderr[-3000:]
    report = json.loads(result.stdout.strip().splitlines()[-1])
    # robot_state_publisher: a TF frame for every link of the URDF.
    assert set(report["links"]) <= set(report["frames"]), sorted(set(report["links"]) - set(report["frames"]))
    rviz_log = (tmp_path / "rviz.log").read_text()
    assert report["rviz_alive"], rviz_log[-2000:]
    assert "Could not load resource" not in rviz_log
    assert "Could not load model" not in rviz_log
    # The screenshot shows the robot: RViz's render panel (blue background) is partly covered.
    image = read_ppm(tmp_path / "rviz.ppm")
    panel = image[100:540, 40:760].astype(int)
    blue = (panel[..., 0] < 40) & (panel[..., 1] < 40) & (panel[..., 2] > 200)
    assert 0.3 < blue.mean() < 0.995, f"background share {blue.mean():.3f}"


def _sdformat(urdf: Path) -> etree._Element:
    if shutil.which("ign") is None:
        pytest.skip("ign (sdformat) is not installed: bash tools/install.sh test")
    result = subprocess.run(["ign", "sdf", "-p", str(urdf)], capture_output=True, text=True, timeout=120, cwd="/")
    assert result.returncode == 0, result.stderr
    return etree.fromstring(result.stdout.encode())


def test_sdformat_output_resolves_its_meshes() -> None:
    model = svhdesc.get("svh_left")
    # package://NAME/... becomes model://NAME/...: Gazebo finds it on its resource path, the folder of packages.
    uris = [u.text.strip() for u in _sdformat(model.urdf_path).iter("uri")]
    assert uris and all(u.startswith(f"model://{model.package_name}/assets/") for u in uris)
    assert all((model.directory.parent / u.removeprefix("model://")).is_file() for u in uris)
    # Without ROS or Gazebo paths: absolute file:// URIs survive the conversion and exist.
    uris = [u.text.strip() for u in _sdformat(model.absolute_urdf_path("file")).iter("uri")]
    assert uris and all(u.startswith("file:///") and Path(u.removeprefix("file://")).is_file() for u in uris)


def test_each_variant_is_a_ros_package_found_on_ros_package_path() -> None:
    from svhdesc.core.source.packages import package_map

    found = package_map({}, env={"ROS_PACKAGE_PATH": str(svhdesc.get("svh_right").directory.parent)})
    for name in svhdesc.variants():
        model = svhdesc.get(name)
        assert found[model.package_name] == model.directory.resolve()
        meshes = [m.get("filename") for m in etree.parse(str(model.urdf_path)).iter("mesh")]
        assert meshes and all(m.startswith(f"package://{model.package_name}/assets/") for m in meshes)
        assert all((model.directory / m.split("/", 3)[3]).is_file() for m in meshes)


def test_absolute_urdf_for_tools_without_ros() -> None:
    model = svhdesc.get("svh_right")
    for uris, prefix in (("path", "/"), ("file", "file:///")):
        path = model.absolute_urdf_path(uris)  # type: ignore[arg-type]
        meshes = [m.get("filename") for m in etree.parse(str(path)).iter("mesh")]
        assert meshes and all(m.startswith(prefix) for m in meshes)
        assert all(Path(m.removeprefix("file://")).is_file() for m in meshes)
        assert path.read_text().count("<joint ") == model.urdf_path.read_text().count("<joint ")
    with pytest.raises(ValueError):
        model.urdf_text("http")  # type: ignore[arg-type]


@pytest.mark.parametrize("uris", ["package", "path"])
def test_mujoco_imports_the_urdf_as_shipped(uris: str, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """MuJoCo's own URDF importer: meshes found, the couplings as joint equalities that hold in simulation."""
    import mujoco

    for name in svhdesc.variants():
        model = svhdesc.get(name)
        path = model.urdf_path if uris == "package" else model.absolute_urdf_path("path")
        monkeypatch.chdir(tmp_path)  # the file alone tells MuJoCo where its meshes are, not the working directory
        mj = mujoco.MjModel.from_xml_path(str(path))
        urdf = etree.parse(str(path)).getroot()
        movable = [j.get("name") for j in urdf.findall("joint") if j.get("type") != "fixed"]
        assert sorted(mj.joint(i).name for i in range(mj.njnt)) == sorted(movable)
        assert mj.ngeom == len(urdf.findall("link/collision")) > 0  # every collision mesh loaded
        mimics = {j.get("name"): j.find("mimic") for j in urdf.findall("joint") if j.find("mimic") is not None}
        assert mj.neq == len(mimics) > 0
        for i in range(mj.neq):
            assert mj.eq_type[i] == mujoco.mjtEq.mjEQ_JOINT
            follower, leader = mj.joint(mj.eq_obj1id[i]).name, mj.joint(mj.eq_obj2id[i]).name
            mimic = mimics.pop(follower)
            assert leader == mimic.get("joint")
            assert mj.eq_data[i][:2].tolist() == [float(mimic.get("offset")), float(mimic.get("multiplier"))]
        assert not mimics
        # The equalities move the followers: channels set mid-range, followers at 0 (off by up to 0.7 rad), 0.3 s
        # later they are on their channel's image. Without gravity, contacts and damping: a URDF has no actuators to
        # hold the hand up, nor the MJCF's contact exclusions, armature and stiff equalities, and the drives' damping
        # on its light links would only slow the followers down (MuJoCo's default equality solref here).
        mj.opt.gravity[:] = 0
        mj.opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_CONTACT
        mj.dof_damping[:] = 0
        data = mujoco.MjData(mj)
        data.qpos[:] = (mj.jnt_range[:, 0] + mj.jnt_range[:, 1]) / 2
        data.qpos[mj.jnt_qposadr[mj.eq_obj1id]] = 0.0
        for _ in range(int(0.3 / mj.opt.timestep)):
            mujoco.mj_step(mj, data)
        for i in range(mj.neq):
            follower, leader = mj.jnt_qposadr[mj.eq_obj1id[i]], mj.jnt_qposadr[mj.eq_obj2id[i]]
            offset, multiplier = mj.eq_data[i][:2]
            assert abs(data.qpos[follower] - (offset + multiplier * data.qpos[leader])) < 1e-3, name


def test_package_xml_is_valid_for_ros() -> None:
    for name in svhdesc.variants():
        package = etree.parse(str(svhdesc.get(name).directory / "package.xml")).getroot()
        assert package.tag == "package" and package.get("format") == "3"
        assert package.findtext("name") == name
        assert package.findtext("version") and package.findtext("license") and package.findtext("maintainer")


def test_invalid_ros_package_name_is_refused(tmp_path: Path) -> None:
    config = tmp_path / "bad.yaml"
    config.write_text(
        f"extends: {REPO / 'config' / 'svhdesc.yaml'}\n"
        f"variants:\n  Bad-Name:\n    xacro: {REPO / 'xacro' / 'svh_hand.urdf.xacro'}\n    args: {{side: right}}\n"
    )
    result = run_cli("build", "--config", str(config), "--out", str(tmp_path / "out"), in_process=True)
    assert result.returncode == 2, result.stderr
    assert result.stderr.startswith(f"error: {config}:3: variant 'Bad-Name' is not a valid ROS package name")
    assert "e.g. 'bad_name'" in result.stderr
    assert "Traceback" not in result.stderr
    assert not (tmp_path / "out" / "Bad-Name").exists()
