"""The right SVH on three arms of example-robot-data (Panda, UR10, Kinova j2s6s200), each from a config with a
``mount`` and no xacro of its own: the arm's own joints and masses, the hand's 9 channels, 11 couplings and 1.3 kg,
arm servos that hold the home pose, a MoveIt config with arm and hand groups, and ``validate`` exit 0."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import yaml
from lxml import etree

from svhdesc.core.settings.config import load_config
from tests.support import REPO, run_cli

mujoco = pytest.importorskip("mujoco")
pytestmark = pytest.mark.slow  # a build and a validate per arm: about a minute each

ARMS = {
    "panda_svh": ["panda_hand", "panda_leftfinger", "panda_rightfinger", "panda_hand_tcp"],
    "ur10_svh": ["ee_link"],
    "kinova_svh": [f"j2s6s200_link_finger{part}_{n}" for part in ("", "_tip") for n in (1, 2)],
}
HAND = "right_hand"
HOLD = 0.002  # rad: every arm joint within it of home for 2 s, gravity on


def config_of(name: str) -> Path:
    return REPO / "examples" / name / f"{name}.yaml"


@pytest.fixture(scope="module", params=list(ARMS))
def arm(request: pytest.FixtureRequest, tmp_path_factory: pytest.TempPathFactory) -> tuple[str, Path]:
    """(variant, its built folder): one build per arm, shared by this module's tests."""
    name = request.param
    out = tmp_path_factory.mktemp(name) / "out"
    result = run_cli("build", "--config", str(config_of(name)), "--out", str(out), in_process=True)
    assert result.returncode == 0, result.stderr
    return name, out / name


def source_masses(name: str) -> dict[str, float]:
    """The arm's link masses as its own URDF gives them (from where pip put example-robot-data)."""
    variant = load_config(config_of(name)).variants[name]
    root = etree.parse(str(variant.xacro)).getroot()
    return {
        link.get("name"): float(link.find("inertial/mass").get("value")) for link in root.iterfind("link[inertial]")
    }


def test_the_arm_keeps_its_joints_and_masses_and_carries_the_hand(arm: tuple[str, Path]) -> None:
    name, folder = arm
    model = mujoco.MjModel.from_xml_path(str(folder / f"{name}.xml"))
    settings = load_config(config_of(name)).variants[name].settings
    joints = [model.joint(j).name for j in range(model.njnt)]
    hand = [j for j in joints if j.startswith(f"{HAND}_")]
    assert [j for j in joints if j not in hand] == settings.arm.joints and len(hand) == 20
    assert model.nu == len(settings.arm.joints) + 9 and model.neq == 11
    bodies = {model.body(b).name: float(model.body_mass[b]) for b in range(model.nbody)}
    assert sum(m for b, m in bodies.items() if b.startswith(f"{HAND}_")) == pytest.approx(1.3, abs=1e-9)
    for link, mass in source_masses(name).items():
        if link in ARMS[name]:
            assert link not in bodies  # mount.remove took the arm's own gripper away
        elif mass > 0:
            assert bodies[link] == pytest.approx(mass, rel=1e-12), link
    parent = settings.mount.parent
    assert model.body(model.body_parentid[model.body(f"{HAND}_base_link").id]).name == parent


def test_the_arm_servos_hold_home(arm: tuple[str, Path]) -> None:
    """Gravity compensated as the shipped UR5 is. Seeded fault: with body gravcomp off, the arms sag 9 to 53 mrad."""
    name, folder = arm
    model = mujoco.MjModel.from_xml_path(str(folder / "scene.xml"))
    data = mujoco.MjData(model)
    mujoco.mj_resetDataKeyframe(model, data, model.key("home").id)
    joints = [j for j in range(model.njnt) if not model.joint(j).name.startswith(HAND)]
    address = model.jnt_qposadr[joints]
    home, worst = data.qpos[address].copy(), 0.0
    for _ in range(int(round(2.0 / model.opt.timestep))):
        mujoco.mj_step(model, data)
        worst = max(worst, float(np.abs(data.qpos[address] - home).max()))
    assert worst < HOLD, worst


def test_moveit_has_the_arm_and_hand_groups(arm: tuple[str, Path]) -> None:
    name, folder = arm
    srdf = etree.parse(str(folder / "config" / f"{name}.srdf")).getroot()
    assert [g.get("name") for g in srdf.iterfind("group")] == ["manipulator", "hand", "arm_hand"]
    hand = [j.get("name") for j in srdf.iterfind("group[@name='hand']/joint")]
    assert len(hand) == 20 and all(j.startswith(f"{HAND}_") for j in hand)
    assert len(srdf.findall("passive_joint")) == 11
    controllers = yaml.safe_load((folder / "config" / "moveit_controllers.yaml").read_text())["controller_list"]
    settings = load_config(config_of(name)).variants[name].settings
    assert [(c["name"], len(c["joints"])) for c in controllers] == [
        (f"{HAND}_controller", 9),
        ("scaled_pos_joint_traj_controller", len(settings.arm.joints)),
    ]


# The suite's time: every check on the first arm; on the others those an arm can change (the hand's own checks,
# on the same hand, give the same verdicts). `svhdesc validate` without --checks runs them all, as the README says.
ARM_CHECKS = (
    "simulate,urdfdom,yourdfpy,sdformat,kinematics,mass_budget,inertia,min_mass,mass_agreement,limits,transmissions,"
    "semantics,self_collision,gravity_hold,range_of_motion"
)


def test_the_arm_validates(arm: tuple[str, Path], tmp_path: Path) -> None:
    name, folder = arm
    report = tmp_path / "report.json"
    args = ("validate", "--config", str(config_of(name)), "--out", str(folder.parent), "--json", str(report))
    every = name == next(iter(ARMS))
    result = run_cli(*args, in_process=True) if every else run_cli(*args, "--checks", ARM_CHECKS, in_process=True)
    assert result.returncode == 0, result.stdout + result.stderr
    checks = {c["name"]: c["status"] for c in json.loads(report.read_text())["variants"][0]["checks"]}
    if every:
        # skipped: the configs name no grasps, and drive no joint by velocity
        assert {n for n, s in checks.items() if s != "pass"} == {"grasps", "velocity_tracking"}
    else:
        assert set(checks) == set(ARM_CHECKS.split(",")) and set(checks.values()) == {"pass"}, checks
