"""What the build emits: couplings, masses, inertias, keyframes, mirror symmetry, kinematics, simulation."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest
import yaml
from lxml import etree

from svhdesc.core.settings.coupling import load_spec, polyval
from tests.support import REPO, VARIANTS, built, model_files

SPEC = load_spec(REPO / "config" / "coupling.yaml")
CONFIG = yaml.safe_load((REPO / "config" / "svhdesc.yaml").read_text())
PREFIX = {"svh_right": "right_hand", "svh_left": "left_hand", "ur5_svh_right": "right_hand"}


def mujoco_model(variant: str) -> mujoco.MjModel:
    return mujoco.MjModel.from_xml_path(str(model_files(variant)[1]))


@pytest.mark.parametrize("variant", VARIANTS)
def test_urdf_mimic_and_mjcf_equality_equal_the_spec(variant: str) -> None:
    urdf_path, mjcf_path = model_files(variant)
    urdf, mjcf = etree.parse(str(urdf_path)), etree.parse(str(mjcf_path))
    prefix = PREFIX[variant]
    assert len(urdf.findall("joint/mimic")) == len(SPEC.couplings) == 11
    assert len(mjcf.findall("equality/joint")) == 11
    for coupling in SPEC.couplings:
        joint, channel = f"{prefix}_{coupling.joint}", f"{prefix}_{coupling.channel}"
        mimic = urdf.find(f"joint[@name='{joint}']/mimic")
        assert mimic.get("joint") == channel
        assert float(mimic.get("offset")) == coupling.coeffs[0]
        assert float(mimic.get("multiplier")) == coupling.coeffs[1]
        equality = mjcf.find(f"equality/joint[@joint1='{joint}']")
        assert equality.get("joint2") == channel
        polycoef = [float(v) for v in equality.get("polycoef").split()]
        assert polycoef == list(coupling.coeffs) + [0.0] * (5 - len(coupling.coeffs))
        plugin = urdf.xpath(f"gazebo/plugin[mimicJoint='{joint}']")[0]
        assert plugin.findtext("joint") == channel
        assert float(plugin.findtext("multiplier")) == coupling.coeffs[1]


@pytest.mark.parametrize("variant", VARIANTS)
def test_masses_follow_the_budget(variant: str) -> None:
    urdf = etree.parse(str(model_files(variant)[0]))
    masses = {
        link.get("name"): float(link.find("inertial/mass").get("value"))
        for link in urdf.findall("link")
        if link.find("inertial") is not None
    }
    hand = sum(m for name, m in masses.items() if name.startswith(PREFIX[variant]))
    assert hand == pytest.approx(1.3, abs=1e-12)
    model = mujoco_model(variant)
    arm = CONFIG["mass"]["links"] if variant.startswith("ur5") else {}
    for link, mass in arm.items():
        assert masses[link] == mass
        assert model.body_mass[model.body(link).id] == pytest.approx(mass, rel=1e-12)
    # Every geometry-less link but the root carries a tiny mass: pybullet and DART would give an
    # inertial-less link 1 kg, and sdformat drops joints hanging from massless links.
    virtual = [link for link in urdf.findall("link") if link.find("visual") is None and link.get("name") != "world"]
    assert len(virtual) >= 8
    for link in virtual:
        assert float(link.find("inertial/mass").get("value")) == 1e-4, link.get("name")
    frames = [link for link in virtual if not link.get("name").startswith(PREFIX[variant])]  # arm frames
    total = 1.3 + sum(arm.values()) + 1e-4 * len(frames)  # hand frames come out of the hand budget
    assert model.body_subtreemass[0] == pytest.approx(total, rel=1e-9)
    assert urdf.find("link[@name='world']/inertial") is None


@pytest.mark.parametrize("variant", VARIANTS)
def test_every_inertia_is_physical(variant: str) -> None:
    urdf = etree.parse(str(model_files(variant)[0]))
    checked = 0
    for inertia in urdf.findall("link/inertial/inertia"):
        i = {k: float(v) for k, v in inertia.attrib.items()}
        tensor = np.array(
            [[i["ixx"], i["ixy"], i["ixz"]], [i["ixy"], i["iyy"], i["iyz"]], [i["ixz"], i["iyz"], i["izz"]]]
        )
        a, b, c = np.linalg.eigvalsh(tensor)
        assert a > 0
        assert a + b >= c * (1 - 1e-9)
        checked += 1
    assert checked >= 23


def test_inertia_is_the_fitted_cylinder() -> None:
    """A finger phalanx is long along its link x axis: the smallest moment must be about x."""
    urdf = etree.parse(str(model_files("svh_right")[0]))
    inertia = urdf.find("link[@name='right_hand_p']/inertial/inertia")
    moments = {k: float(inertia.get(k)) for k in ("ixx", "iyy", "izz")}
    assert min(moments, key=moments.get) == "ixx"


@pytest.mark.parametrize("variant", VARIANTS)
def test_keyframes_hold_the_thesis_poses_and_follow_the_spec(variant: str) -> None:
    model = mujoco_model(variant)
    prefix = PREFIX[variant]
    for name in ("home", "test"):
        key = model.key(name)
        expected = CONFIG["keyframes"][name]
        qpos = {model.joint(j).name: key.qpos[model.jnt_qposadr[j]] for j in range(model.njnt)}
        for joint, value in expected.items():
            full = joint if joint.endswith("_joint") else f"{prefix}_{joint}"
            if full in qpos:
                assert qpos[full] == value
            else:
                assert variant.startswith("svh") and joint.endswith("_joint")
        for coupling in SPEC.couplings:
            channel = qpos[f"{prefix}_{coupling.channel}"]
            assert qpos[f"{prefix}_{coupling.joint}"] == pytest.approx(polyval(coupling.coeffs, channel), abs=1e-12)
        # The servos hold the keyframe: ctrl equals the actuated joints' positions.
        for a in range(model.nu):
            assert key.ctrl[a] == pytest.approx(qpos[model.joint(model.actuator_trnid[a, 0]).name])
    if variant.startswith("svh"):
        assert model.nq == 20


def _world_vertices(model: mujoco.MjModel, data: mujoco.MjData, group: int) -> dict[str, np.ndarray]:
    clouds = {}
    for g in range(model.ngeom):
        if model.geom_group[g] != group or model.geom_type[g] != mujoco.mjtGeom.mjGEOM_MESH:
            continue
        mesh = model.geom_dataid[g]
        start, count = model.mesh_vertadr[mesh], model.mesh_vertnum[mesh]
        local = model.mesh_vert[start : start + count]
        world = local @ data.geom_xmat[g].reshape(3, 3).T + data.geom_xpos[g]
        body = model.body(model.geom_bodyid[g]).name.split("_hand_", 1)[1]
        clouds[body] = world
    return clouds


def test_left_hand_is_the_mirror_image_of_the_right() -> None:
    right, left = mujoco_model("svh_right"), mujoco_model("svh_left")
    rd, ld = mujoco.MjData(right), mujoco.MjData(left)
    rng = np.random.default_rng(7)
    for _ in range(5):
        q = rng.uniform(right.jnt_range[:, 0], right.jnt_range[:, 1])
        rd.qpos[:], ld.qpos[:] = q, q
        mujoco.mj_kinematics(right, rd)
        mujoco.mj_kinematics(left, ld)
        for body in range(1, right.nbody):
            name = right.body(body).name.replace("right_hand", "left_hand").replace("svh_right", "svh_left")
            mirrored = rd.xpos[body] * np.array([-1.0, 1.0, 1.0])
            np.testing.assert_allclose(ld.xpos[left.body(name).id], mirrored, atol=1e-9)
        mujoco.mj_forward(right, rd)
        mujoco.mj_forward(left, ld)
        for group in (2, 3):  # visual and collision geometry alike
            rc, lc = _world_vertices(right, rd, group), _world_vertices(left, ld, group)
            assert rc.keys() == lc.keys() and len(rc) >= 23
            for body, cloud in rc.items():
                mirrored = cloud * np.array([-1.0, 1.0, 1.0])
                other = lc[body]
                assert other.shape == mirrored.shape
                np.testing.assert_allclose(np.sort(other, axis=0), np.sort(mirrored, axis=0), atol=1e-6)


@pytest.mark.parametrize("variant", VARIANTS)
def test_random_targets_for_two_seconds_warning_free_and_coupled(variant: str) -> None:
    model = mujoco_model(variant)
    data = mujoco.MjData(model)
    rng = np.random.default_rng(1)
    every = round(0.1 / model.opt.timestep)
    worst = 0.0
    for step in range(round(2.0 / model.opt.timestep)):
        if step % every == 0:
            data.ctrl[:] = rng.uniform(model.actuator_ctrlrange[:, 0], model.actuator_ctrlrange[:, 1])
        mujoco.mj_step(model, data)
        for e in range(model.neq):
            follower = data.qpos[model.jnt_qposadr[model.eq_obj1id[e]]]
            leader = data.qpos[model.jnt_qposadr[model.eq_obj2id[e]]]
            worst = max(worst, abs(follower - polyval(tuple(model.eq_data[e, :5]), leader)))
    assert [w.number for w in data.warning] == [0] * len(data.warning)
    assert np.isfinite(data.qpos).all()
    assert worst < 1e-3


@pytest.mark.parametrize("variant", VARIANTS)
def test_urdf_and_mjcf_describe_the_same_kinematics(variant: str) -> None:
    import yourdfpy

    urdf_path, _ = model_files(variant)
    urdf = yourdfpy.URDF.load(str(urdf_path), build_scene_graph=True, load_meshes=False)
    model = mujoco_model(variant)
    data = mujoco.MjData(model)
    rng = np.random.default_rng(3)
    actuated = [j for j in urdf.actuated_joint_names]
    for _ in range(20):
        data.qpos[:] = rng.uniform(model.jnt_range[:, 0], model.jnt_range[:, 1])
        for e in range(model.neq):  # propagate the couplings
            leader = data.qpos[model.jnt_qposadr[model.eq_obj2id[e]]]
            data.qpos[model.jnt_qposadr[model.eq_obj1id[e]]] = polyval(tuple(model.eq_data[e, :5]), leader)
        mujoco.mj_kinematics(model, data)
        cfg = {j: data.qpos[model.jnt_qposadr[model.joint(j).id]] for j in actuated}
        urdf.update_cfg(cfg)
        for link in urdf.link_map:
            if link == "world":
                continue
            frame = urdf.get_transform(link, "world")
            body = model.body(link).id
            np.testing.assert_allclose(data.xpos[body], frame[:3, 3], atol=1e-6)
            rotation = data.xmat[body].reshape(3, 3).T @ frame[:3, :3]
            angle = np.arccos(np.clip((np.trace(rotation) - 1) / 2, -1, 1))
            assert angle < 1e-6


@pytest.mark.slow
def test_outputs_are_byte_identical_across_builds(tmp_path) -> None:  # type: ignore[no-untyped-def]
    from tests.support import run_cli

    result = run_cli("build", "svh_left", "--out", str(tmp_path), in_process=True)
    assert result.returncode == 0, result.stderr
    first = built() / "svh_left"
    for path in sorted(first.rglob("*")):
        if path.is_file():
            assert (tmp_path / "svh_left" / path.relative_to(first)).read_bytes() == path.read_bytes(), path
