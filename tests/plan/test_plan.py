"""svhdesc.plan / `svhdesc plan`: OMPL on the generated MoveIt config, MuJoCo collision checks, Ruckig timing."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

from svhdesc.plan import Obstacle, Planner
from tests.support import run_cli

VARIANT = "ur5_svh_right"
# A box where the straight joint-space motion from home to test sweeps the hand.
WALL = Obstacle("wall", "box", (0.06, 0.06, 0.06), (-0.108, 0.726, 0.237))


@pytest.fixture(scope="module")
def planner() -> Planner:
    return Planner(VARIANT)


def _check_timing(plan, config) -> None:  # noqa: ANN001
    joints = plan.joint_names
    positions, velocities, accelerations = map(np.asarray, (plan.positions, plan.velocities, plan.accelerations))
    assert np.all(np.diff(plan.times) > 0)
    vmax = np.array([config.max_velocity[j] for j in joints]) * config.velocity_scaling
    amax = np.array([config.max_acceleration[j] for j in joints]) * config.acceleration_scaling
    assert np.all(np.abs(velocities) <= vmax + 1e-6)
    assert np.all(np.abs(accelerations) <= amax + 1e-6)
    lower = np.array([config.lower[j] for j in joints])
    upper = np.array([config.upper[j] for j in joints])
    assert np.all(positions >= lower - 1e-9) and np.all(positions <= upper + 1e-9)
    np.testing.assert_allclose(positions[0], plan.waypoints[0], atol=1e-9)
    np.testing.assert_allclose(positions[-1], plan.waypoints[-1], atol=1e-6)
    assert np.allclose(velocities[[0, -1]], 0, atol=1e-12)  # rest to rest (Ruckig leaves ~1e-16)


def _swept_valid(planner: Planner, plan, rest) -> bool:  # noqa: ANN001
    """Every 5 mrad along the straight segments between the waypoints is collision-free."""
    index = planner.scene.joint_index(plan.joint_names)
    planner.scene.set_state(rest)
    for a, b in zip(plan.waypoints, plan.waypoints[1:]):
        a, b = np.asarray(a), np.asarray(b)
        steps = max(1, int(np.ceil(np.abs(b - a).max() / 0.005)))
        for k in range(steps + 1):
            if not planner.scene.valid(index, a + (b - a) * k / steps):
                return False
    return True


def _pad_under_the_fingertip(depth: float) -> Obstacle:
    """A small box whose top is ``depth`` above the lowest vertex of the index fingertip's hulls at `home`."""
    planner = Planner(VARIANT)
    scene = planner.scene
    scene.set_state(planner.resolve("hand", "home"))
    model, data = scene.model, scene.data
    tip = model.body("right_hand_t").id
    lowest = None
    for geom in np.flatnonzero((model.geom_bodyid == tip) & (model.geom_contype > 0)):
        mesh = model.geom_dataid[geom]
        start, count = model.mesh_vertadr[mesh], model.mesh_vertnum[mesh]
        points = data.geom_xpos[geom] + model.mesh_vert[start : start + count] @ data.geom_xmat[geom].reshape(3, 3).T
        candidate = points[np.argmin(points[:, 2])]
        lowest = candidate if lowest is None or candidate[2] < lowest[2] else lowest
    half = 0.01
    return Obstacle("pad", "box", (half, half, half), (lowest[0], lowest[1], lowest[2] + depth - half))


def test_the_validity_check_agrees_with_the_reported_pairs() -> None:
    """valid() (the planner's hot path, decided on MuJoCo's contact arrays) says what colliding_pairs() says, over
    random states of the arm and of the hand and states near a start whose fingertip rests 0.2 mm deep on a pad
    (allowed to go on touching by up to TOUCH, no deeper). Seeded faults: the start's touching pairs never allowed
    (`_may_touch` left empty); allowed at any depth (TOUCH not applied): each disagreed near the start."""
    pad = Planner(VARIANT, [_pad_under_the_fingertip(2e-4)])
    scene, config = pad.scene, pad.config
    rng = np.random.default_rng(3)
    seen = {"valid": 0, "invalid": 0, "valid while touching": 0}
    for group, rest, spread in (
        ("manipulator", "home", None),
        ("hand", "test", None),
        ("hand", "home", 0.02),
        ("manipulator", "home", 0.003),
    ):
        joints = config.active(group)
        index = scene.joint_index(joints)
        start = pad.resolve(group, rest)
        scene.set_state(start)
        low, high = (np.array([bound[j] for j in joints]) for bound in (config.lower, config.upper))
        if spread is not None:  # near the start, within the joints' limits
            centre = np.array([start[j] for j in joints])
            low, high = np.maximum(low, centre - spread), np.minimum(high, centre + spread)
        for values in rng.uniform(low, high, (300, len(joints))):
            verdict = scene.valid(index, values)
            assert verdict == (not scene.colliding_pairs(index, values)), (group, rest, values.tolist())
            seen["valid" if verdict else "invalid"] += 1
            seen["valid while touching"] += bool(verdict and (scene.data.contact.dist < -1e-6).any())
    print(seen)
    assert all(seen.values()), seen


def test_home_to_test_is_timed_within_the_limits(planner: Planner) -> None:
    plan = planner.plan("manipulator", "home", goal="test")
    assert plan.success, plan.message
    assert plan.joint_names == [
        "shoulder_pan_joint",
        "shoulder_lift_joint",
        "elbow_joint",
        "wrist_1_joint",
        "wrist_2_joint",
        "wrist_3_joint",
    ]
    _check_timing(plan, planner.config)
    test = planner.config.state("manipulator", "test")
    np.testing.assert_allclose(plan.waypoints[-1], [test[j] for j in plan.joint_names])


def test_a_wall_forces_a_detour_that_stays_clear(planner: Planner) -> None:
    walled = Planner(VARIANT, [WALL])
    rest = walled.resolve("manipulator", "home")
    straight = type("P", (), {"joint_names": walled.config.active("manipulator")})()
    home, test = walled.resolve("manipulator", "home"), walled.resolve("manipulator", "test")
    straight.waypoints = [[home[j] for j in straight.joint_names], [test[j] for j in straight.joint_names]]
    assert not _swept_valid(walled, straight, rest)  # the direct motion hits the wall
    plan = walled.plan("manipulator", "home", goal="test", timeout=30.0)  # ends at the first solution
    assert plan.success, plan.message
    assert len(plan.waypoints) > 2 and _swept_valid(walled, plan, rest)
    _check_timing(plan, walled.config)


def test_pose_goal_reaches_the_tool_pose(planner: Planner) -> None:
    pose = (0.2, 0.5, 0.3, math.pi, 0.0, 0.3)
    plan = planner.plan("manipulator", "home", pose=pose)
    assert plan.success, plan.message
    end = planner.resolve("manipulator", "home")
    end.update(zip(plan.joint_names, plan.positions[-1]))
    from svhdesc.plan.ik import pose_matrix

    reached = planner.kinematics().tip_pose("manipulator", end)
    np.testing.assert_allclose(reached, pose_matrix(pose), atol=1e-4)


def test_hand_plans_channels_and_coupled_joints_follow(planner: Planner) -> None:
    plan = planner.plan("hand", "home", goal="test")
    assert plan.success and len(plan.joint_names) == 9 and "right_hand_j12" not in plan.joint_names
    scene = planner.scene
    scene.set_state({"right_hand_Ring_Finger": 0.5})
    j12 = scene.data.qpos[scene.joint_index(["right_hand_j12"])[0]]
    assert j12 == pytest.approx(1.3588 * 0.5, abs=1e-3)  # the coupling polynomial of config/coupling.yaml


def test_a_goal_in_collision_fails_cleanly(planner: Planner) -> None:
    blocked = Planner(VARIANT, [Obstacle("block", "box", (0.1, 0.1, 0.1), (-0.108, 0.843, 0.05))])
    plan = blocked.plan("manipulator", "home", goal="test")
    assert not plan.success and "goal state in collision" in plan.message


def _floor_state(planner: Planner, wrist_1: float) -> dict[str, float]:
    """The arm stretched out at base height, 0.1 rad down; the hand's pitch set by wrist_1: at -2.2 and -0.4 it
    points sideways (clear), around -1.3 down into the simulation's floor (0.3 m below the base)."""
    state = planner.resolve("manipulator", "home")
    state.update(shoulder_lift_joint=0.1, elbow_joint=0.0, wrist_1_joint=wrist_1)
    return state


def test_the_simulations_floor_is_in_the_planners_scene(planner: Planner) -> None:
    """The planner checks against scene.xml, what `svhdesc sim` (and so `plan --execute`) runs: a goal in its floor
    is refused and a motion whose straight path dips into the floor goes around it. Seeded fault: the floor and
    pedestal dropped from the planner's scene (contype 0), the same goal is accepted and the straight path passes."""
    model = planner.scene.model
    world = [g for g in range(model.ngeom) if model.geom_bodyid[g] == 0]
    assert {model.geom(g).name for g in world} == {"floor", "pedestal"}
    start, clear, under = (_floor_state(planner, w) for w in (-2.2, -0.4, -1.3))
    refused = planner.plan("manipulator", start, goal=under)
    assert not refused.success and "goal state in collision: world-" in refused.message
    plan = planner.plan("manipulator", start, goal=clear, timeout=10.0)
    assert plan.success, plan.message
    joints = plan.joint_names
    straight = type(
        "P", (), {"joint_names": joints, "waypoints": [[start[j] for j in joints], [clear[j] for j in joints]]}
    )
    assert not _swept_valid(planner, straight, start)  # the direct motion hits the floor...
    assert len(plan.waypoints) > 2 and _swept_valid(planner, plan, start)  # ...the plan does not
    saved = model.geom_contype[world].copy(), model.geom_conaffinity[world].copy()
    try:
        model.geom_contype[world] = model.geom_conaffinity[world] = 0
        assert planner.plan("manipulator", start, goal=under).success
        assert _swept_valid(planner, straight, start)
    finally:
        model.geom_contype[world], model.geom_conaffinity[world] = saved


def test_cli_writes_json_and_refuses_bad_input(tmp_path: Path) -> None:
    out = tmp_path / "plan.json"
    result = run_cli("plan", VARIANT, "--group", "manipulator", "--from", "home", "--to", "test", "--json", str(out))
    assert result.returncode == 0, result.stderr
    document = json.loads(out.read_text())
    assert document["success"] is True and document["planning_time"] > 0
    assert len(document["joint_names"]) == 6 and document["points"][-1]["time_from_start"] == document["duration"]
    scene = tmp_path / "scene.yaml"
    scene.write_text(
        "obstacles:\n- {name: block, shape: box, size: [0.1, 0.1, 0.1], position: [-0.108, 0.843, 0.05]}\n"
    )
    failed = run_cli("plan", VARIANT, "--group", "manipulator", "--from", "home", "--to", "test", "--scene", str(scene))
    assert failed.returncode == 1 and "goal state in collision" in failed.stderr
    for args, culprit in (
        (("--group", "nope", "--from", "home", "--to", "test"), "nope"),
        (("--group", "manipulator", "--from", "home"), "--to"),
        (("--group", "manipulator", "--from", "1,2", "--to", "test"), "2 values"),
        (("--group", "manipulator", "--from", "home", "--to", "test", "--planner", "Magic"), "Magic"),
    ):
        bad = run_cli("plan", VARIANT, *args)
        assert bad.returncode == 2 and bad.stderr.startswith("error:") and culprit in bad.stderr, bad.stderr
        assert "Traceback" not in bad.stderr
    scene.write_text("obstacles:\n- {shape: sphere, size: [1], position: [0, 0, 0]}\n")
    bad = run_cli("plan", VARIANT, "--group", "manipulator", "--from", "home", "--to", "test", "--scene", str(scene))
    assert bad.returncode == 2 and f"{scene}:2:" in bad.stderr  # the entry's line


def test_sim_scene_adds_objects_and_refuses_bad_files(tmp_path: Path) -> None:
    scene = tmp_path / "scene.yaml"
    scene.write_text(
        "obstacles:\n- {name: table, shape: box, size: [0.5, 0.3, 0.02], position: [0, 0.6, -0.22]}\n"
        "- {name: can, shape: cylinder, size: [0.025, 0.06], position: [0.1, 0.6, -0.14], mass: 0.1}\n"
    )
    result = run_cli("sim", VARIANT, "--scene", str(scene), "--duration", "0.5", "--track", "can")
    assert result.returncode == 0, result.stderr
    line = next(x for x in result.stdout.splitlines() if x.strip().startswith("can:"))
    z = float(line.split("xyz")[1].split()[2])
    assert z == pytest.approx(-0.14, abs=0.002)  # the free can stands on the table (it would fall without it)
    for text, culprit in (
        ("obstacles:\n- {name: x, shape: box, size: [1, 1], position: [0, 0, 0]}\n", "scene.yaml:2:"),
        ("obstacles:\n- {name: x, shape: box, size: [1, 1, 1], position: [0, 0, 0], mass: -1}\n", "mass"),
        ("obstacles:\n- {name: x, shape: box, size: [1, 1, .nan], position: [0, 0, 0]}\n", "finite"),
        ("obstacles: 3\n", "obstacles:"),
        ("{{{", "not YAML"),
    ):
        scene.write_text(text)
        bad = run_cli("sim", VARIANT, "--scene", str(scene), "--duration", "0.1")
        assert bad.returncode == 2 and bad.stderr.startswith("error:") and culprit in bad.stderr, bad.stderr
        assert "Traceback" not in bad.stderr


def test_cli_same_seed_same_path(tmp_path: Path) -> None:
    scene = tmp_path / "scene.yaml"
    x, y, z = WALL.position
    scene.write_text(f"obstacles:\n- {{name: wall, shape: box, size: [0.06, 0.06, 0.06], position: [{x}, {y}, {z}]}}\n")
    paths = []
    for k in range(2):
        out = tmp_path / f"plan{k}.json"
        args = ("--group", "manipulator", "--from", "home", "--to", "test", "--scene", str(scene), "--json", str(out))
        result = run_cli("plan", VARIANT, *args, "--seed", "5")
        assert result.returncode == 0, result.stderr
        paths.append(json.loads(out.read_text())["waypoints"])
    assert paths[0] == paths[1] and len(paths[0]) > 2  # a detour, found the same way twice
