"""A policy of svh_rotate driving the ROS 2 node as it would drive the real hand (``svhdesc deploy``): the simulation
(main model, the task's scene and reset state) in one process, the policy node (rclpy + onnxruntime) in another,
inside ``unshare -n`` with discovery on localhost, both in the ROS 2 venv.

The same policy, seed and number of control periods run in process on the main model (MuJoCo C through the task's
own environment) give the reference: after 2 s the hand's nine channels, as the policy node last read them from
/joint_states, are within ``BOUND`` of it, both ways the policy node commands the servos:
- ``--via trajectory`` (the default), with the controllers as SCHUNK's driver ships them: ``right_hand`` active and
  the forward position controller inactive before, during and after (nothing is switched), one JointTrajectory
  point per control period on ``/right_hand/joint_trajectory``;
- ``--via forward``: ``forward_position_controller`` switched in, ``/forward_position_controller/commands``.
The policy is a one-iteration one (what it does matters less than that every path does the same with it).

Also: ``trajectory_plan`` (which active controller gets which joints, from list_controllers), the generated
``config/forward_position_controller.yaml`` fragment of every variant (read by PyYAML and by rcl's own parameter
parser, the channels in the driver's order, nothing of SCHUNK's file overridden) and deploy's error without ROS 2.

Seeded faults (each failed the test, then reverted): the policy node publishing its targets in reversed joint order
(forward: the channels 0.343 rad apart); the streamed JointTrajectory naming the joints in reversed order beside
positions in the policy's order (0.579 rad apart); the observer not writing the tracked cube's pose (the actor
sees the cube where the reset put it: 0.139 rad apart); the forward controller left inactive (the switch skipped:
the commands are ignored and the test fails). In-test: a fragment with its joints reversed, and an ``update_rate``
in it, are reported.
"""

from __future__ import annotations

import json
import shlex
import subprocess
import sys
from pathlib import Path
from types import SimpleNamespace
from typing import Any

import numpy as np
import pytest
import yaml

from tests.netns import private_namespace
from tests.ros2.support import PYTHON, private_env, why_not
from tests.support import REPO, VARIANTS, run_cli

pytest.importorskip("torch")
pytest.importorskip("rsl_rl")

pytestmark = [pytest.mark.ros, pytest.mark.slow]

DURATION = 2.0  # s of simulated time the policy acts
STEPS = round(DURATION * 25.0)  # svh_rotate's control periods
BOUND = 0.03  # rad between the ROS 2 run's channels and the in-process run's
FRAGMENT = Path("ros2") / "config" / "forward_position_controller.yaml"
JTC = "joint_trajectory_controller/JointTrajectoryController"


@pytest.fixture(scope="module")
def policy(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("rotate-policy") / "run"
    result = run_cli(
        "train", "svh_rotate", "--backend", "mujoco", "--envs", "2", "--iterations", "1", "--out", str(out), cwd=REPO
    )
    assert result.returncode == 0, result.stderr
    return out / "policy.onnx"


@pytest.fixture(scope="module")
def reference(policy: Path) -> list[float]:
    """The channels after STEPS control periods in process (MuJoCo C, the task's environment)."""
    import torch

    from svhdesc.learn import task
    from svhdesc.learn.deploy import nominal
    from svhdesc.learn.env import TaskEnv
    from svhdesc.learn.policy import OnnxPolicy

    rotate = task("svh_rotate")
    act = OnnxPolicy(policy, rotate)
    env = TaskEnv(nominal(rotate), 1, backend="mujoco", source="main", seed=1)
    for _ in range(STEPS):
        env.step(torch.as_tensor(act(env.observe()[0].numpy())))
    return env.joint_pos()[0].tolist()


def deployed(policy: Path, work: Path, via: str) -> dict[str, Any]:
    why = why_not()
    if why:
        pytest.skip(why)
    python = shlex.quote(str(PYTHON))
    command = f"{python} -m svhdesc.cli deploy svh_rotate --policy {shlex.quote(str(policy))} --duration {DURATION}"
    script = f"ip link set lo up && cd {shlex.quote(str(work))} && exec {command} --seed 1 --via {via}"
    namespace = private_namespace()
    assert isinstance(namespace, list)
    result = subprocess.run(
        [*namespace, "sh", "-c", script], env=private_env(work), capture_output=True, text=True, timeout=600
    )
    lines = [line for line in result.stdout.splitlines() if line.startswith("{")]
    assert result.returncode == 0 and lines, f"exit {result.returncode}\n{result.stdout[-2000:]}{result.stderr[-3000:]}"
    assert "Traceback" not in result.stderr, result.stderr[-3000:]
    return json.loads(lines[-1])


def _as_in_process(verdict: dict[str, Any], reference: list[float], via: str) -> None:
    assert verdict["ticks"] == STEPS and verdict["steps"] == STEPS and verdict["via"] == via, verdict
    assert verdict["score_name"] == "yaw rate (rad/s)" and np.isfinite(verdict["score"])
    gap = np.abs(np.array(verdict["joints"]) - np.array(reference))
    print(f"channels through ROS 2 (--via {via}) vs in process: {gap.max():.4f} rad at most", file=sys.stderr)
    assert gap.max() < BOUND, (verdict["joints"], reference)


def test_policy_drives_the_shipped_configuration_through_the_trajectory_topic(
    policy: Path, reference: list[float], tmp_path: Path
) -> None:
    verdict = deployed(policy, tmp_path, "trajectory")
    assert verdict["controllers"] == ["right_hand"], verdict
    for active in (verdict["active_before"], verdict["active_after"]):  # nothing switched
        assert active == ["joint_state_broadcaster", "right_hand"], verdict
    _as_in_process(verdict, reference, "trajectory")


def test_policy_drives_the_forward_controller_when_asked(policy: Path, reference: list[float], tmp_path: Path) -> None:
    verdict = deployed(policy, tmp_path, "forward")
    assert verdict["controllers"] == ["forward_position_controller"], verdict
    assert verdict["active_before"] == ["joint_state_broadcaster", "right_hand"], verdict
    assert verdict["active_after"] == ["forward_position_controller", "joint_state_broadcaster"], verdict
    _as_in_process(verdict, reference, "forward")


def _state(name: str, state: str, joints: list[str], kind: str = JTC) -> SimpleNamespace:
    claimed = [f"{joint}/position" for joint in joints] if state == "active" else []
    return SimpleNamespace(name=name, state=state, type=kind, claimed_interfaces=claimed)


def test_the_trajectory_plan_is_the_active_trajectory_controllers_over_the_joints() -> None:
    from svhdesc.errors import SvhdescError
    from svhdesc.learn.ros2_policy import trajectory_plan

    hand = [f"Right_Hand_{c}" for c in ("Thumb_Flexion", "Pinky", "Finger_Spread")]
    arm = ["shoulder_pan_joint", "elbow_joint"]
    forward = "position_controllers/JointGroupPositionController"
    shipped = [_state("joint_state_broadcaster", "active", []), _state("right_hand", "active", hand)]
    assert trajectory_plan([*shipped, _state("forward_position_controller", "inactive", hand, forward)], hand) == [
        ("right_hand", [0, 1, 2])
    ]
    both = [
        *shipped,
        _state("scaled_joint_trajectory_controller", "active", arm, "ur_controllers/ScaledJointTrajectoryController"),
    ]
    assert trajectory_plan(both, [arm[0], hand[1], arm[1], hand[0]]) == [
        ("scaled_joint_trajectory_controller", [0, 2]),
        ("right_hand", [1, 3]),
    ]
    # Seeded: the hand's controller inactive, or only a forward controller active over the joints.
    for controllers in (
        [_state("right_hand", "inactive", hand)],
        [_state("right_hand", "inactive", hand), _state("forward_position_controller", "active", hand, forward)],
    ):
        with pytest.raises(SvhdescError, match="no active joint trajectory controller commands Right_Hand_Thumb"):
            trajectory_plan(controllers, hand)


def fragment_problems(document: dict, full: dict, channels: list[str]) -> list[str]:
    """What keeps the fragment from being what a real-hand user adds to SCHUNK's configuration for --via forward."""
    from svhdesc.model import ROS2_FORWARD_TYPE

    settings = document["controller_manager"]["ros__parameters"]
    problems = [f"sets {key}" for key, value in settings.items() if not isinstance(value, dict)]
    manager = {name: value for name, value in settings.items() if isinstance(value, dict)}
    problems += [f"{name} is a {v['type']}" for name, v in manager.items() if v.get("type") != ROS2_FORWARD_TYPE]
    hands = [name for name in manager if document[name]["ros__parameters"]["joints"] == channels]
    if len(hands) != 1:
        problems.append(f"no forward controller over {channels} in order")
    for name in manager:  # the same controllers as the package's own file: nothing of SCHUNK's overridden
        if document[name] != full.get(name) or manager[name] != full["controller_manager"]["ros__parameters"][name]:
            problems.append(f"{name} differs from ros2_controllers.yaml")
    return problems


def channels(variant: str) -> list[str]:
    """The hand's channels in the driver's order, under their ROS 2 names (the model's contract)."""
    from svhdesc.model import DRIVER_CHANNELS, get, ros2_joint_name

    return [ros2_joint_name(f"{get(variant).hand.prefix}_{channel}") for channel in DRIVER_CHANNELS]


def test_the_forward_fragment_names_the_channels_in_order() -> None:
    for variant in VARIANTS:
        folder = REPO / "generated" / variant
        document = yaml.safe_load((folder / FRAGMENT).read_text())
        full = yaml.safe_load((folder / "ros2" / "config" / "ros2_controllers.yaml").read_text())
        assert fragment_problems(document, full, channels(variant)) == [], variant
    # Seeded: the channels reversed; the fragment setting the controller manager's rate.
    variant = "ur5_svh_right"
    folder = REPO / "generated" / variant
    document = yaml.safe_load((folder / FRAGMENT).read_text())
    full = yaml.safe_load((folder / "ros2" / "config" / "ros2_controllers.yaml").read_text())
    document["right_hand_forward_position_controller"]["ros__parameters"]["joints"].reverse()
    assert "no forward controller over" in " ".join(fragment_problems(document, full, channels(variant)))
    document = yaml.safe_load((folder / FRAGMENT).read_text())
    document["controller_manager"]["ros__parameters"]["update_rate"] = 125
    assert fragment_problems(document, full, channels(variant)) == ["sets update_rate"]


def test_rcl_reads_the_forward_fragment_with_the_declared_types() -> None:
    """rcl's parameter-file parser (what ros2_control_node's --params-file goes through), in the ROS 2 venv."""
    if not PYTHON.is_file():
        pytest.skip(f"no ROS 2 Python at {PYTHON}")
    files = [str(REPO / "generated" / variant / FRAGMENT) for variant in VARIANTS]
    script = (
        "import json, sys\nfrom pathlib import Path\nfrom tests.ros2.test_parameter_files import parse, type_errors\n"
        "found = [parse(Path(f)) for f in sys.argv[1:]]\n"
        "print(json.dumps([[type_errors(p), p] if p is not None else None for p in found]))"
    )
    result = subprocess.run(
        [str(PYTHON), "-c", script, *files], cwd=REPO, capture_output=True, text=True, timeout=120, check=False
    )
    assert result.returncode == 0, result.stderr[-2000:]
    for variant, parsed in zip(VARIANTS, json.loads(result.stdout)):
        assert parsed is not None, f"rcl refuses {variant}'s fragment"
        errors, parameters = parsed
        assert errors == [], (variant, errors)
        hand = [
            node for node, values in parameters.items() if values.get("joints") == ["string_array", channels(variant)]
        ]
        assert len(hand) == 1 and parameters["controller_manager"][f"{hand[0]}.type"][1].endswith("PositionController")


def test_deploy_without_ros2_names_only_deploys_own_options(policy: Path, tmp_path: Path) -> None:
    """Issue 48: the error named a ``--ros2`` option deploy does not have."""
    pytest.importorskip("onnxruntime")
    try:
        import rclpy  # noqa: F401

        pytest.skip("rclpy is importable here")
    except ImportError:
        pass
    result = run_cli("deploy", "svh_rotate", "--policy", str(policy), "--duration", "0.1", cwd=tmp_path)
    errors = [line for line in result.stderr.splitlines() if line.startswith("error:")]
    assert result.returncode == 2 and len(errors) == 1 and "Traceback" not in result.stderr, result.stderr
    assert ".venv-ros2/bin/svhdesc deploy TASK --policy F" in errors[0] and "--ros2" not in errors[0], errors[0]
    assert list(tmp_path.iterdir()) == []


def test_the_cli_offers_the_paths_the_policy_node_has() -> None:
    from svhdesc.cli import deploy_command
    from svhdesc.learn.deploy import VIA

    via = next(p for p in deploy_command.params if p.name == "via")
    assert list(via.type.choices) == list(VIA) and via.default == VIA[0]  # the default: SCHUNK's configuration
