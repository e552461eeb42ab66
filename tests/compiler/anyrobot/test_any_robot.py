"""Third-party URDFs through the compiler: stated defaults with one warning per fix, <mimic> tags as the
coupling spec, `svhdesc init` and its bad inputs (docs/any-robot.md).

Seeded faults (each made a test here fail when tried): giving geometry-less frames no inertial again
(panda_link8 mass 0 -> 'inertia not positive definite'); ignoring mass.links for a geometry-less link (the
sphere's mass test); dropping the <mimic> -> spec step ('nothing drives it'); init writing kp 1000 for every
joint is not caught here, but init writing no `home` or a home outside a limit is (test_init_home_in_limits).
"""

from __future__ import annotations

import importlib.util
from pathlib import Path

import mujoco
import pytest
import yaml

from tests.support import run_cli

PYBULLET = Path(next(iter(importlib.util.find_spec("pybullet_data").submodule_search_locations)))  # type: ignore[union-attr]
PANDA = PYBULLET / "franka_panda" / "panda.urdf"

# The Panda of the pybullet wheel, as a user writes its config from docs/any-robot.md alone.
USER_CONFIG = """
packages: {meshes: python:pybullet_data/franka_panda/meshes}
arm:
  enabled: true
  joints: [panda_joint1, panda_joint2, panda_joint3, panda_joint4, panda_joint5, panda_joint6, panda_joint7]
mass:
  links: {panda_grasptarget: 0.05}
collision: {mode: hull}
variants:
  panda: {xacro: python:pybullet_data/franka_panda/panda.urdf}
"""


@pytest.fixture(scope="module")
def panda(tmp_path_factory: pytest.TempPathFactory):  # type: ignore[no-untyped-def]
    folder = tmp_path_factory.mktemp("panda")
    (folder / "panda.yaml").write_text(USER_CONFIG)
    result = run_cli("build", "--config", str(folder / "panda.yaml"), "--out", str(folder / "out"), in_process=True)
    return folder, result


@pytest.mark.slow
def test_pybullet_panda_builds_from_a_user_config(panda) -> None:  # type: ignore[no-untyped-def]
    folder, result = panda
    assert result.returncode == 0, result.stderr
    # one warning line per fixed link, naming it
    frames = [line for line in result.stderr.splitlines() if "panda_link8" in line]
    assert len(frames) == 1 and "tiny inertial" in frames[0]
    model = mujoco.MjModel.from_xml_path(str(folder / "out" / "panda" / "panda.xml"))
    assert model.nq == 9 and model.nu == 8  # 7 arm servos and the finger channel
    assert model.neq == 1  # the finger <mimic> became a coupling equality
    body = model.body("panda_link8").id
    assert model.body_mass[body] == pytest.approx(1e-4)


@pytest.mark.slow
def test_mass_links_applies_to_a_link_without_geometry(panda) -> None:  # type: ignore[no-untyped-def]
    folder, result = panda
    model = mujoco.MjModel.from_xml_path(str(folder / "out" / "panda" / "panda.xml"))
    # fused or not, the grasp target's 50 g must be in the model (a sphere of 1 cm radius, with a warning)
    assert any("panda_grasptarget" in line and "0.05 kg" in line for line in result.stderr.splitlines())
    assert model.body_subtreemass[0] == pytest.approx(17.96 + 0.05 + 1e-4, abs=1e-6)


def _init(tmp_path: Path, source: Path, *extra: str, in_process: bool = False):  # type: ignore[no-untyped-def]
    return run_cli("init", str(source), "--out", str(tmp_path / "robot.yaml"), *extra, in_process=in_process)


@pytest.mark.slow
def test_init_then_build_pybullet_panda(tmp_path: Path) -> None:
    result = _init(tmp_path, PANDA)
    assert result.returncode == 0, result.stderr
    config = yaml.safe_load((tmp_path / "robot.yaml").read_text())
    spec = yaml.safe_load((tmp_path / "robot.coupling.yaml").read_text())
    assert config["coupling"] == "robot.coupling.yaml"
    assert spec["couplings"] == [{"joint": "panda_finger_joint2", "follows": "panda_finger_joint1", "poly": [0.0, 1.0]}]
    assert config["arm"]["joints"] == [f"panda_joint{i}" for i in range(1, 8)]
    assert config["packages"] == {"meshes": "python:pybullet_data/franka_panda/meshes"}
    built = run_cli("build", "--config", str(tmp_path / "robot.yaml"), "--out", str(tmp_path / "out"), in_process=True)
    assert built.returncode == 0, built.stderr


def test_init_home_clear_of_the_stops_and_damping_from_the_rating(tmp_path: Path) -> None:
    """A joint whose range excludes 0 gets the middle of its range; one whose 0 lies near a stop (the Panda's wrist,
    -0.0175 .. 3.7525) is moved 10 % of its range inside. Each arm joint's damping is effort / velocity (j3: the
    source's 20, larger). Seeded: `_home` back to 0-where-allowed made j3's home 0.0 and failed here."""
    urdf = tmp_path / "two.urdf"
    urdf.write_text(
        '<robot name="two"><link name="a"/><link name="b"/><link name="c"/><link name="d"/>'
        '<joint name="j1" type="revolute"><parent link="a"/><child link="b"/><axis xyz="0 0 1"/>'
        '<limit lower="0.5" upper="1.5" effort="10" velocity="1"/></joint>'
        '<joint name="j2" type="continuous"><parent link="b"/><child link="c"/><axis xyz="0 0 1"/>'
        '<limit effort="5" velocity="2"/></joint>'
        '<joint name="j3" type="revolute"><parent link="c"/><child link="d"/><axis xyz="0 0 1"/>'
        '<limit lower="-0.0175" upper="3.7525" effort="12" velocity="2.61"/><dynamics damping="20"/></joint></robot>'
    )
    assert _init(tmp_path, urdf).returncode == 0
    config = yaml.safe_load((tmp_path / "robot.yaml").read_text())
    assert config["keyframes"]["home"] == {"j1": 1.0, "j2": 0.0, "j3": pytest.approx(0.3595)}
    assert config["arm"]["kp"] == [100.0, 50.0, 120.0]
    assert config["joints"] == {"j1": {"damping": 10.0}, "j2": {"damping": 2.5}, "j3": {"damping": 20.0}}


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("<sdf version='1.6'/>", "not a URDF"),
        ("<robot name='r'><link name='a'/></robot>", "no movable joint"),
        (
            "<robot name='r'><link name='a'><visual><geometry><mesh filename='gone.stl'/></geometry></visual></link>"
            "<link name='b'/><joint name='j' type='continuous'><parent link='a'/><child link='b'/></joint></robot>",
            "gone.stl",
        ),
        ("not xml at all <", "robot.urdf"),
        (
            "<robot name='r'><link name='w'/><link name='b'/><joint name='base' type='floating'><parent link='w'/>"
            "<child link='b'/></joint></robot>",
            "type 'floating' is not supported: svhdesc builds fixed-base robots",
        ),
        (
            "<robot name='r'><link name='w'/><link name='b'/><joint name='base' type='planar'><parent link='w'/>"
            "<child link='b'/></joint></robot>",
            "type 'planar' is not supported",
        ),
    ],
)
def test_init_bad_input(tmp_path: Path, text: str, message: str) -> None:
    source = tmp_path / "robot.urdf"
    source.write_text(text)
    result = _init(tmp_path, source, in_process=True)  # they fail early: no interpreter start
    assert result.returncode == 2
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error:") and message in lines[0], result.stderr
    assert not (tmp_path / "robot.yaml").exists()  # no partial output


def test_init_missing_file(tmp_path: Path) -> None:
    result = _init(tmp_path, tmp_path / "nope.urdf", in_process=True)
    assert result.returncode == 2 and result.stderr.startswith("error:") and "nope.urdf" in result.stderr
