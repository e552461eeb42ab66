"""A trained policy driving the ROS 2 node as it would drive the real hand (``svhdesc deploy TASK --policy F``).

Two processes, as on the robot:
- the simulation (``svhdesc.ros2.node.serve``) on the task's scene built from the main model (noslip,
  multi-contact), started in the state the task's reset gives for ``--seed``, publishing each object's pose as a
  tracker would (``/tracked/<object>``, geometry_msgs/PoseStamped) beside the drivers' interfaces;
- the policy node (``python -m svhdesc.learn.ros2_policy``, rclpy + onnxruntime): at the task's control rate
  (simulated time) it builds the actor's observation from ``/joint_states`` and the tracker with the task's own
  terms, runs the ONNX actor and sends the servo targets ``--via``:
  ``trajectory`` (default) one JointTrajectory point per control period on ``/<controller>/joint_trajectory`` of
  the active trajectory controllers, nothing switched (the driver's configuration as SCHUNK ships it), or
  ``forward`` on ``/<forward controller>/commands`` (std_msgs/Float64MultiArray, the controller's joint order)
  after one STRICT ``switch_controller`` swaps the forward position controllers in.

The policy node measures the episode with the task's own ``update``, ``success`` and ``score`` on what it observed
(object velocities from successive tracker poses) and prints one JSON line at the end.
"""

from __future__ import annotations

import dataclasses
import json
import math
import subprocess
import sys
import threading
from pathlib import Path
from typing import Any

import numpy as np

from svhdesc.errors import SvhdescError
from svhdesc.learn.spec import Randomisation, Task

SETTLE = 0.2  # s of simulated time the node runs before the policy acts: the controllers come up
VIA = (
    "trajectory",
    "forward",
)  # how the policy node commands the servos (svhdesc.learn.ros2_policy); the default first
MISSING_ROS2 = (
    "deploy needs ROS 2 Jazzy's rclpy, trajectory_msgs and controller_manager_msgs, which {python} cannot import "
    "({why}): run .venv-ros2/bin/svhdesc deploy TASK --policy F, made by `bash tools/install.sh ros2`"
)


def nominal(task: Task) -> Task:
    """The task as deployed: nominal object and servos, and no noise or latency added (the real ones are there)."""
    return dataclasses.replace(task, randomisation=Randomisation())


class Observer:
    """The task's environment, one world of MuJoCo C on the main model, used only to observe: measured joint
    positions and tracked poses are written into it, kinematics run, and the task's terms read from it."""

    def __init__(self, task: Task, seed: int) -> None:
        from svhdesc.learn.env import TaskEnv
        from svhdesc.model import ros2_joint_name

        self.task = nominal(task)
        self.env = TaskEnv(self.task, 1, backend="mujoco", source="main", seed=seed)
        from svhdesc.model import scalar_joints

        m = self.env.mjm
        self.columns = {ros2_joint_name(m.joint(j).name): int(m.jnt_qposadr[j]) for j in scalar_joints(m)}
        self.objects = [shape.name for shape in self.task.scene.objects]
        self.command: Any = None  # the last commands sent
        self._last: dict[str, tuple[float, np.ndarray, np.ndarray]] = {}

    def initial_qpos(self) -> list[float]:
        return self.env.qpos[0].tolist()

    def write(self, now: float, positions: dict[str, float], poses: dict[str, tuple[list[float], list[float]]]) -> None:
        """One control period's measurements: joints by ROS 2 name, objects' (position, quaternion w x y z)."""
        import torch

        env = self.env
        qpos, qvel = env.qpos[0], env.qvel[0]
        for name, value in positions.items():
            if name in self.columns:
                qpos[self.columns[name]] = value
        for body, (position, quaternion) in poses.items():
            qadr, dadr = env.free[body]
            pos, quat = np.asarray(position), np.asarray(quaternion)
            qpos[qadr : qadr + 3] = torch.as_tensor(pos)
            qpos[qadr + 3 : qadr + 7] = torch.as_tensor(quat)
            qvel[dadr : dadr + 6] = torch.as_tensor(self._velocity(body, now, pos, quat))
        env.physics.kinematics()

    def _velocity(self, body: str, now: float, pos: np.ndarray, quat: np.ndarray) -> np.ndarray:
        """Linear (world) and angular (body frame, as MuJoCo's free joint) velocity from the last two poses."""
        last = self._last.get(body)
        self._last[body] = (now, pos, quat)
        if last is None or now <= last[0]:
            return np.zeros(6)
        dt = now - last[0]
        w0, v0 = last[2][0], last[2][1:]
        w1, v1 = quat[0], quat[1:]
        # body-frame rotation from the last orientation to this one: conj(q0) * q1
        dw = w0 * w1 + v0 @ v1
        dv = w0 * v1 - w1 * v0 - np.cross(v0, v1)
        angle = 2.0 * math.atan2(float(np.linalg.norm(dv)), abs(float(dw)))
        axis = dv / np.linalg.norm(dv) if np.linalg.norm(dv) > 1e-12 else np.zeros(3)
        return np.concatenate(((pos - last[1]) / dt, axis * np.sign(dw or 1.0) * angle / dt))

    def actor(self) -> np.ndarray:
        self.env.sense()
        return self.env.observe()[0].cpu().numpy()

    def acted(self, action: np.ndarray) -> list[float]:
        """Record the action (the next observation's last action) and return the commands to send: the hand's
        servo targets as they are (its firmware ramps them, in the simulation as on the hand), an arm's joints
        ramped at their rated speeds here, as the task's environment ramps them (a forward controller would not)."""
        import torch

        env = self.env
        env.previous_action, env.action = env.action, torch.as_tensor(action, dtype=torch.float32).reshape(1, -1)
        env.episode_length_buf += 1
        if env.task.update is not None:
            env.task.update(env)
        targets = env.targets(env.action)[0]
        hand = torch.tensor([env.is_hand(a) for a in env.actuators])
        if self.command is None:
            self.command = env.setpoint[0].clone()
        step = torch.maximum(torch.minimum(targets - self.command, env.ramp), -env.ramp)
        self.command = torch.where(hand, targets, self.command + step)
        # in double precision within each servo's range (float32's rounding can step 1e-8 past a range's end)
        limited = env.mjm.actuator_ctrllimited.astype(bool)
        low = np.where(limited, env.mjm.actuator_ctrlrange[:, 0], -np.inf)
        high = np.where(limited, env.mjm.actuator_ctrlrange[:, 1], np.inf)
        return np.clip(self.command.double().cpu().numpy(), low, high).tolist()

    def verdict(self) -> dict[str, Any]:
        env = self.env
        result = {
            "steps": int(env.episode_length_buf[0]),
            "success": bool(env.task.success(env)[0]),
            "joints": [round(float(q), 6) for q in env.joint_pos()[0]],  # as the last /joint_states gave them
        }
        if env.task.score is not None:
            result["score"] = float(env.task.score(env)[0])
            result["score_name"] = env.task.score_name
        return result


def task_simulation(task: Task, seed: int, policy: Any = None) -> Any:
    """The ROS 2 node's Simulation: the task's scene on the main model, in the state the task's reset gives (and,
    given an OnnxPolicy, checked to fit the task's observations and actions)."""
    from svhdesc.learn.scene import dress
    from svhdesc.sim import Simulation

    deployed = nominal(task)
    sim = Simulation(task.scene.variant, keyframe=None, edit=lambda spec: dress(spec, deployed.scene))
    observer = Observer(task, seed)
    if policy is not None:
        policy.check_fits(observer.env)
    start = observer.initial_qpos()
    if len(start) != sim.model.nq:
        raise SvhdescError(f"task {task.name}: the simulation has {sim.model.nq} positions, the task {len(start)}")
    sim.data.qpos[:] = start
    targets = observer.env.targets(observer.env.action)[0].tolist()
    sim.set_targets(dict(zip(observer.env.actuators, targets)))
    return sim


def require_ros2() -> None:
    """What the policy node and the simulation node import from ROS 2, or one error naming deploy's own way to
    get it (the ROS 2 venv)."""
    try:
        import controller_manager_msgs.srv  # noqa: F401
        import rclpy  # noqa: F401
        import trajectory_msgs.msg  # noqa: F401
    except ImportError as exc:  # ModuleNotFoundError, or a wheel whose native library does not load
        raise SvhdescError(MISSING_ROS2.format(python=sys.executable, why=exc)) from None


def run(task: Task, policy: Path, seed: int, duration: float, via: str = VIA[0]) -> dict[str, Any]:
    """Serve the task's simulation over ROS 2 in real time, as the robot runs, while the policy node drives it for
    ``duration`` simulated seconds through ``via`` (one of ``VIA``); the policy node's verdict (its JSON line).
    The node stops when the policy node ends."""
    from svhdesc.learn.policy import OnnxPolicy

    if via not in VIA:
        raise SvhdescError(f"--via must be one of {', '.join(VIA)}, not {via!r}")
    actor = OnnxPolicy(policy, task)  # a policy of another task fails here, before anything starts
    sim = task_simulation(task, seed, actor)
    require_ros2()
    from svhdesc.ros2.node import serve

    objects = [shape.name for shape in task.scene.objects]
    verdict: dict[str, Any] = {}

    def start_policy(node: Any) -> None:
        module = "svhdesc.learn.ros2_policy"
        command = [sys.executable, "-m", module, task.name, str(policy), str(seed), str(duration), via]
        child = subprocess.Popen(command, stdout=subprocess.PIPE, text=True)

        def wait() -> None:
            out, _ = child.communicate()
            lines = [line for line in out.splitlines() if line.startswith("{")]
            verdict.update(json.loads(lines[-1]) if lines else {"error": f"policy node exited {child.returncode}"})
            node.stop()

        threading.Thread(target=wait, daemon=True).start()

    serve(sim, track=objects, realtime=True, on_start=start_policy)
    if "error" in verdict:
        raise SvhdescError(f"policy node: {verdict['error']}")
    return verdict
