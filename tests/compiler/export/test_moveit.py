"""The generated MoveIt config, cross-checked against the URDF and the MJCF of each variant."""

from __future__ import annotations

import os
import subprocess
from pathlib import Path

import numpy as np
import pytest
import yaml
from lxml import etree

import svhdesc
from svhdesc.core.settings.config import load_config
from svhdesc.ros1.system import ros_available
from tests.support import REPO, VARIANTS

mujoco = pytest.importorskip("mujoco")

REASONS = {"Adjacent", "Default", "Always", "Never"}
SAMPLES = 200  # the build drew 2000 with another seed: these poses are new to it


def _files(variant: str) -> tuple[etree._ElementTree, etree._ElementTree, Path]:
    model = svhdesc.get(variant)
    config = model.directory / "config"
    return etree.parse(str(config / f"{variant}.srdf")), etree.parse(str(model.urdf_path)), config


@pytest.mark.parametrize("variant", VARIANTS)
def test_srdf_names_exist_in_the_urdf(variant: str) -> None:
    srdf, urdf, _ = _files(variant)
    links = {link.get("name") for link in urdf.iterfind("link")}
    joints = {j.get("name"): j for j in urdf.iterfind("joint")}
    movable = {name for name, j in joints.items() if j.get("type") != "fixed"}
    mimic = {name for name, j in joints.items() if j.find("mimic") is not None}
    groups = {g.get("name"): g for g in srdf.iterfind("group")}
    assert "hand" in groups
    if variant.startswith("ur5"):
        assert {"manipulator", "arm_hand"} <= set(groups)
        chain = groups["manipulator"].find("chain")
        assert (chain.get("base_link"), chain.get("tip_link")) == ("base_link", "tool0")
        assert [g.get("name") for g in groups["arm_hand"].iterfind("group")] == ["manipulator", "hand"]
        effector = srdf.find("end_effector")
        assert effector.get("parent_link") in links and effector.get("group") == "hand"
    hand = [j.get("name") for j in groups["hand"].iterfind("joint")]
    assert len(hand) == 20 and set(hand) <= movable
    passive = {p.get("name") for p in srdf.iterfind("passive_joint")}
    assert passive == mimic and len(passive) == 11
    virtual = srdf.find("virtual_joint")
    assert virtual.get("child_link") in links and virtual.get("child_link") not in {
        j.find("child").get("link") for j in joints.values()
    }
    model = svhdesc.load_mujoco(variant)
    for state in srdf.iterfind("group_state"):
        assert state.get("group") in groups
        key = model.key(state.get("name"))  # from the keyframes: their pose, not a grasp's targets past it
        actuated = {model.actuator(a).name for a in range(model.nu)}
        values = {j.get("name"): float(j.get("value")) for j in state.iterfind("joint")}
        assert set(values) == actuated and not set(values) & passive
        for name, value in values.items():
            limit = joints[name].find("limit")
            assert float(limit.get("lower")) - 1e-9 <= value <= float(limit.get("upper")) + 1e-9
            assert value == pytest.approx(key.qpos[model.joint(name).qposadr[0]])
    # Every keyframe (home, test and the grasp postures) becomes a group state.
    keyframes = set(load_config(REPO / "config" / "svhdesc.yaml").variants[variant].settings.keyframes)
    assert {"home", "test", "pinch"} <= keyframes
    assert {s.get("name") for s in srdf.iterfind("group_state")} == keyframes


def _collision_links(urdf: etree._ElementTree) -> set[str]:
    return {link.get("name") for link in urdf.iterfind("link") if link.find("collision") is not None}


@pytest.mark.parametrize("variant", VARIANTS)
def test_disabled_pairs_have_reasons_and_adjacent_means_connected(variant: str) -> None:
    srdf, urdf, _ = _files(variant)
    colliding = _collision_links(urdf)
    parent = {j.find("child").get("link"): j.find("parent").get("link") for j in urdf.iterfind("joint")}
    pairs = [(d.get("link1"), d.get("link2"), d.get("reason")) for d in srdf.iterfind("disable_collisions")]
    assert len({(a, b) for a, b, _ in pairs}) == len(pairs)
    reasons = {r for _, _, r in pairs}
    assert reasons <= REASONS and {"Adjacent", "Never"} <= reasons
    for a, b, reason in pairs:
        assert a in colliding and b in colliding, (a, b)
        if reason == "Adjacent":

            def geometric_parent(link: str) -> str | None:
                up = parent.get(link)
                while up is not None and up not in colliding:
                    up = parent.get(up)
                return up

            assert geometric_parent(a) == b or geometric_parent(b) == a, (a, b)


def _never_colliding_model(variant: str):
    spec = mujoco.MjSpec.from_file(str(svhdesc.get(variant).mjcf_path))
    for exclude in list(spec.excludes):
        spec.delete(exclude)
    model = spec.compile()
    model.opt.disableflags |= int(mujoco.mjtDisableBit.mjDSBL_FILTERPARENT)
    return model


@pytest.mark.parametrize("variant", VARIANTS)
def test_never_pairs_do_not_collide_in_fresh_random_poses(variant: str) -> None:
    srdf, _, _ = _files(variant)
    never = {
        frozenset((d.get("link1"), d.get("link2")))
        for d in srdf.iterfind("disable_collisions")
        if d.get("reason") == "Never"
    }
    checked = {
        frozenset((d.get("link1"), d.get("link2")))
        for d in srdf.iterfind("disable_collisions")
        if d.get("reason") != "Never"
    }
    model = _never_colliding_model(variant)
    data = mujoco.MjData(model)
    rng = np.random.default_rng(12345)
    actuated = [model.actuator_trnid[a, 0] for a in range(model.nu)]
    equalities = [(model.eq_obj1id[e], model.eq_obj2id[e], model.eq_data[e, :5]) for e in range(model.neq)]
    seen_pairs: set[frozenset[str]] = set()
    for _ in range(SAMPLES):
        for a, joint in enumerate(actuated):
            low, high = model.actuator_ctrlrange[a]
            data.qpos[model.jnt_qposadr[joint]] = rng.uniform(low, high)
        for follower, leader, poly in equalities:
            q = data.qpos[model.jnt_qposadr[leader]]
            data.qpos[model.jnt_qposadr[follower]] = sum(c * q**k for k, c in enumerate(poly))
        mujoco.mj_kinematics(model, data)
        mujoco.mj_collision(model, data)
        for contact in data.contact[: data.ncon]:
            if contact.dist < 0:
                bodies = frozenset(model.body(model.geom_bodyid[g]).name for g in (contact.geom1, contact.geom2))
                seen_pairs.add(bodies)
    assert not seen_pairs & never, sorted(tuple(p) for p in seen_pairs & never)
    # The probe sees collisions at all: touching pairs exist and every one of them is disabled
    # for a reason other than Never, or is a pair the planner must check.
    assert seen_pairs and seen_pairs & checked


@pytest.mark.parametrize("variant", VARIANTS)
def test_controllers_match_transmissions_and_the_node(variant: str) -> None:
    _, urdf, config = _files(variant)
    interfaces = {
        t.find("joint").get("name"): t.findtext("joint/hardwareInterface") for t in urdf.iterfind("transmission")
    }
    moveit = yaml.safe_load((config / "moveit_controllers.yaml").read_text())
    ros_control = yaml.safe_load((config / "ros_controllers.yaml").read_text())
    names = [c["name"] for c in moveit["controller_list"]]
    prefix = "left_hand" if "left" in variant else "right_hand"
    expected = [f"{prefix}_controller"] + (["scaled_pos_joint_traj_controller"] if variant.startswith("ur5") else [])
    assert names == expected
    controlled = [j for c in moveit["controller_list"] for j in c["joints"]]
    assert sorted(controlled) == sorted(interfaces)  # every transmission, once
    for controller in moveit["controller_list"]:
        assert controller["type"] == "FollowJointTrajectory" and controller["action_ns"] == "follow_joint_trajectory"
        own = ros_control[controller["name"]]
        assert own["joints"] == controller["joints"]
        kind = {interfaces[j] for j in own["joints"]}
        assert kind == {"hardware_interface/PositionJointInterface"}
        assert own["type"] == "position_controllers/JointTrajectoryController"
    limits = yaml.safe_load((config / "joint_limits.yaml").read_text())["joint_limits"]
    for name, limit in limits.items():
        velocity = float(urdf.find(f"joint[@name='{name}']/limit").get("velocity"))
        assert limit["max_velocity"] == velocity and limit["has_velocity_limits"]
    kinematics = yaml.safe_load((config / "kinematics.yaml").read_text())
    assert ("manipulator" in kinematics) == variant.startswith("ur5")


@pytest.mark.skipif(not ros_available(), reason="Debian's ROS 1 is not installed")
def test_roslaunch_loads_the_moveit_parameters() -> None:
    model = svhdesc.get("ur5_svh_right")
    env = {**os.environ, "ROS_PACKAGE_PATH": str(model.directory.parent), "ROS_HOME": "/tmp"}
    result = subprocess.run(
        ["roslaunch", "--dump-params", str(model.directory / "launch" / "moveit.launch")],
        env=env,
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert result.returncode == 0, result.stderr
    params = yaml.safe_load(result.stdout)
    assert params["/robot_description_semantic"] == (model.directory / "config" / "ur5_svh_right.srdf").read_text()
    assert params["/robot_description_planning/joint_limits/shoulder_pan_joint/max_velocity"] > 0
    assert params["/robot_description_kinematics/manipulator/kinematics_solver"].startswith("kdl")
    assert len(params["/move_group/controller_list"]) == 2
