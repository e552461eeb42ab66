"""``TaskEnv``: any ``Task`` over any physics backend, as rsl-rl's ``VecEnv``.

One control step: the policy's action becomes servo targets (the driver's 9 channels, plus the arm's joints where the
task has an arm), the physics takes ``substeps`` steps, then terminations, rewards and resets are evaluated and the
observations assembled, all as torch tensors on the physics' device. Resets are masks over the worlds (``where``),
so a step needs no host round trip but one: whether any world reset at all (then kinematics runs once).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import torch

from svhdesc.errors import SvhdescError
from svhdesc.learn.mdp import where_rows
from svhdesc.learn.physics import Physics, make_physics
from svhdesc.learn.scene import compose
from svhdesc.learn.spec import Obs, Task

try:  # rsl-rl's interface, where installed (the rl extra); the environment works without it (deployment)
    from rsl_rl.env import VecEnv as _Base
except ImportError:  # pragma: no cover - exercised where rsl-rl is missing
    _Base = object  # type: ignore[assignment,misc]

ACTION_CLIP = 4.0  # |action| beyond this adds nothing: every target is already clipped to its range


class TaskEnv(_Base):  # type: ignore[misc,valid-type]
    """``num_envs`` worlds of ``task``; ``backend`` "warp" (``device`` cpu or cuda) or "mujoco" (MuJoCo C)."""

    def __init__(
        self,
        task: Task,
        num_envs: int,
        device: str = "cpu",
        backend: str = "warp",
        source: str = "batch",
        seed: int = 0,
        physics: Physics | None = None,
    ) -> None:
        if num_envs < 1:
            raise SvhdescError(f"--envs must be at least 1, not {num_envs}")
        self.task = task
        self.num_envs = num_envs
        if physics is None:
            mjm = compose(task.scene, source)
            physics = make_physics(mjm, num_envs, device, backend, task.scene.nconmax, task.scene.njmax)
        self.physics = physics
        self.mjm = physics.mjm
        self.device = physics.device
        self.dt = 1.0 / task.control_hz
        self.substeps = _substeps(self.dt, float(self.mjm.opt.timestep))
        self.max_episode_length = max(1, round(task.episode_s * task.control_hz))
        self.episode_length_buf = torch.zeros(num_envs, dtype=torch.long, device=self.device)
        self.cfg = {"task": task.name, "control_hz": task.control_hz, "substeps": self.substeps}
        self.generator = torch.Generator(device=self.device).manual_seed(seed)
        self._index()
        self.num_actions = len(self.actuators)
        self.action = torch.zeros(num_envs, self.num_actions, device=self.device)
        self.commands: dict[str, torch.Tensor] = {}  # per-task state (targets), kept by its resets
        self.nominal = {name: value.clone() for name, value in self.physics.model.items()}
        self.latency = torch.zeros(num_envs, dtype=torch.long, device=self.device)
        self._history: torch.Tensor | None = None
        self._cursor = 0
        self._fresh = torch.zeros(num_envs, dtype=torch.bool, device=self.device)  # worlds reset since sense()
        self.stats = EpisodeStats(self.device)
        self.restart()

    # -- the model's layout ------------------------------------------------------------------------------------
    def _index(self) -> None:
        import mujoco

        from svhdesc.model import HandId, get

        self.hand = get(self.task.scene.variant).hand or HandId(None, None)
        m = self.mjm
        self.actuators = [m.actuator(a).name for a in range(m.nu)]
        joints = [int(m.actuator_trnid[a, 0]) for a in range(m.nu)]
        self.act_qpos = torch.tensor([int(m.jnt_qposadr[j]) for j in joints], device=self.device)
        self.act_dof = torch.tensor([int(m.jnt_dofadr[j]) for j in joints], device=self.device)
        low, high = m.actuator_ctrlrange.T
        self.ctrl_low = torch.tensor(low, dtype=torch.float32, device=self.device)
        self.ctrl_high = torch.tensor(high, dtype=torch.float32, device=self.device)
        actions = self.task.actions
        default = [actions.default.get(self.channel_name(n), 0.0) for n in self.actuators]
        self.default_ctrl = torch.tensor(default, dtype=torch.float32, device=self.device)
        scales = [self._scale(n) for n in self.actuators]
        self.action_scale = torch.tensor(scales, dtype=torch.float32, device=self.device)
        self.ramp = self.dt * self._velocity_limits()  # rad per control period; inf: no ramp
        self.bodies = {m.body(b).name: b for b in range(m.nbody)}
        self._coupled = _coupled_columns(m, self.device)
        self.free = {}
        for j in range(m.njnt):
            if int(m.jnt_type[j]) == int(mujoco.mjtJoint.mjJNT_FREE):
                self.free[m.body(int(m.jnt_bodyid[j])).name] = (int(m.jnt_qposadr[j]), int(m.jnt_dofadr[j]))

    def _velocity_limits(self) -> torch.Tensor:
        """Each actuator's joint's URDF velocity limit (rad/s): the SVH firmware's setpoint ramp for the hand's
        channels, the rated joint speed for an arm's (a UR moves no faster whatever it is commanded)."""
        from svhdesc.model import get, urdf_velocity_limits

        limits = urdf_velocity_limits(get(self.task.scene.variant).urdf_path) if self.task.actions.ramp else {}
        joints = [self.mjm.joint(int(self.mjm.actuator_trnid[a, 0])).name for a in range(self.mjm.nu)]
        speeds = [limits.get(j, math.inf) for j in joints]
        return torch.tensor(speeds, dtype=torch.float32, device=self.device)

    def channel_name(self, actuator: str) -> str:
        """An actuator's name without the hand's prefix (the built model's, svhdesc.model's HandId): the driver's
        channel name (``Thumb_Flexion``); an arm's joint keeps its name."""
        return self.hand.short(actuator) if self.hand.owns(actuator) else actuator

    def is_hand(self, actuator: str) -> bool:
        return self.hand.owns(actuator) and self.channel_name(actuator) in _channels()

    def _scale(self, actuator: str) -> float:
        actions = self.task.actions
        if not self.is_hand(actuator) and actions.arm_scale is not None:
            return actions.arm_scale
        return actions.scale

    # -- state a term reads --------------------------------------------------------------------------------------
    @property
    def qpos(self) -> torch.Tensor:
        return self.physics.state["qpos"]

    @property
    def qvel(self) -> torch.Tensor:
        return self.physics.state["qvel"]

    def joint_pos(self) -> torch.Tensor:
        """The actuated joints' positions, in actuator order (the driver's channel order for the hand)."""
        return self.qpos[:, self.act_qpos]

    def joint_vel(self) -> torch.Tensor:
        return self.qvel[:, self.act_dof]

    def body_pos(self, name: str) -> torch.Tensor:
        return self.physics.state["xpos"][:, self.bodies[name]]

    def body_quat(self, name: str) -> torch.Tensor:
        return self.physics.state["xquat"][:, self.bodies[name]]

    def object_pos(self, name: str) -> torch.Tensor:
        adr = self.free[name][0]
        return self.qpos[:, adr : adr + 3]

    def object_quat(self, name: str) -> torch.Tensor:
        adr = self.free[name][0]
        return self.qpos[:, adr + 3 : adr + 7]

    def object_linvel(self, name: str) -> torch.Tensor:
        adr = self.free[name][1]
        return self.qvel[:, adr : adr + 3]

    def object_angvel(self, name: str) -> torch.Tensor:
        """World-frame angular velocity (MuJoCo's free joint keeps it in the body's frame)."""
        from svhdesc.learn.mdp import quat_rotate

        adr = self.free[name][1]
        return quat_rotate(self.object_quat(name), self.qvel[:, adr + 3 : adr + 6])

    def geom_id(self, name: str) -> int:
        import mujoco

        return mujoco.mj_name2id(self.mjm, mujoco.mjtObj.mjOBJ_GEOM, name)

    def uniform(self, low: float, high: float, *shape: int) -> torch.Tensor:
        """Uniform draws from the environment's own generator (seeded: the same seed, the same episodes)."""
        size = (self.num_envs, *shape)
        return low + (high - low) * torch.rand(size, generator=self.generator, device=self.device)

    # -- writing state in a reset --------------------------------------------------------------------------------
    def set_qpos(self, mask: torch.Tensor, columns: Sequence[int] | torch.Tensor, values: torch.Tensor) -> None:
        qpos = self.qpos
        qpos[:, columns] = where_rows(mask, values, qpos[:, columns])

    def set_joints(self, mask: torch.Tensor, targets: torch.Tensor) -> None:
        """The actuated joints at ``targets`` [nenv, nu] and every coupled joint where its coupling puts it."""
        values = [targets]
        columns = [self.act_qpos]
        for column, leader, coeffs in self._coupled:
            lead = targets[:, leader]
            values.append(sum(c * lead**k for k, c in enumerate(coeffs)).unsqueeze(-1))
            columns.append(torch.tensor([column], device=self.device))
        self.set_qpos(mask, torch.cat(columns), torch.cat(values, dim=-1))

    def set_object(self, mask: torch.Tensor, name: str, pos: torch.Tensor, quat: torch.Tensor) -> None:
        qadr, dadr = self.free[name]
        self.set_qpos(mask, list(range(qadr, qadr + 7)), torch.cat((pos, quat), dim=-1))
        qvel = self.qvel
        qvel[:, dadr : dadr + 6] = where_rows(
            mask, torch.zeros_like(qvel[:, dadr : dadr + 6]), qvel[:, dadr : dadr + 6]
        )

    def set_model(self, mask: torch.Tensor, field: str, index: Any, values: torch.Tensor) -> None:
        """Per-world model parameter ``field[index]`` (e.g. ("geom_friction", (geom, 0))) in the masked worlds."""
        target = self.physics.model[field]
        view = target[(slice(None), *index)] if isinstance(index, tuple) else target[:, index]
        view.copy_(where_rows(mask, values.to(view.dtype), view))

    # -- VecEnv ------------------------------------------------------------------------------------------------------
    def reset(self) -> Any:
        self.restart()
        return self.get_observations()

    def restart(self) -> None:
        """Every world to a new episode (what ``reset`` does, without building rsl-rl's TensorDict)."""
        everyone = torch.ones(self.num_envs, dtype=torch.bool, device=self.device)
        self._reset(everyone)
        self.physics.kinematics()
        self.sense()

    def _reset(self, mask: torch.Tensor) -> None:
        self.physics.clear(mask)
        self._randomise(mask)
        self.task.reset(self, mask)
        self.physics.commit_model()
        qvel = self.qvel
        hand = self.act_dof
        qvel[:, hand] = where_rows(mask, torch.zeros_like(qvel[:, hand]), qvel[:, hand])
        ctrl = self.physics.state["ctrl"]
        ctrl.copy_(where_rows(mask, self.targets(torch.zeros_like(self.action)), ctrl))
        self.setpoint = ctrl.clone()
        self.action = where_rows(mask, torch.zeros_like(self.action), self.action)
        self.episode_length_buf = torch.where(mask, torch.zeros_like(self.episode_length_buf), self.episode_length_buf)
        low, high = self.task.randomisation.latency
        lag = torch.randint(low, high + 1, (self.num_envs,), generator=self.generator, device=self.device)
        self.latency = torch.where(mask, lag, self.latency)
        self._fresh = self._fresh | mask

    def _randomise(self, mask: torch.Tensor) -> None:
        r = self.task.randomisation
        gain = self.uniform(*r.servo_gain, 1)
        for field, column in (("actuator_gainprm", 0), ("actuator_biasprm", 1), ("actuator_biasprm", 2)):
            nominal = self.nominal[field][:, :, column]
            self.set_model(mask, field, (slice(None), column), nominal * gain)
        damping = self.uniform(*r.joint_damping, 1)
        self.set_model(mask, "dof_damping", slice(None), self.nominal["dof_damping"] * damping)

    def targets(self, action: torch.Tensor) -> torch.Tensor:
        """Servo targets of an action: ``default + scale * action``, clipped to each actuator's range."""
        raw = self.default_ctrl + self.action_scale * action
        return torch.maximum(torch.minimum(raw, self.ctrl_high), self.ctrl_low)

    def step(self, actions: torch.Tensor) -> tuple[Any, torch.Tensor, torch.Tensor, dict[str, Any]]:
        action = actions.to(self.device).clamp(-ACTION_CLIP, ACTION_CLIP)
        self.setpoint = self.setpoint + torch.maximum(
            torch.minimum(self.targets(action) - self.setpoint, self.ramp), -self.ramp
        )
        self.physics.state["ctrl"].copy_(self.setpoint)
        self.previous_action, self.action = self.action, action
        self.physics.step(self.substeps)
        self.episode_length_buf += 1
        if self.task.update is not None:
            self.task.update(self)
        terms = {r.name: r.fn(self) * r.weight for r in self.task.rewards}
        reward = torch.stack(list(terms.values())).sum(0) * self.dt if terms else torch.zeros(self.num_envs)
        failed = torch.zeros(self.num_envs, dtype=torch.bool, device=self.device)
        time_out = self.episode_length_buf >= self.max_episode_length
        for done in self.task.dones:
            hit = done.fn(self).bool()
            if done.time_out:
                time_out = time_out | hit
            else:
                failed = failed | hit
        diverged = self.physics.diverged()
        # A blown-up world's reward says nothing and can be huge or NaN, which turns PPO's update into NaN weights
        reward = torch.where(diverged, torch.zeros_like(reward), reward)
        failed = failed | diverged
        time_out = time_out & ~diverged
        ended = failed | time_out
        self.stats.add(self, ended, failed, reward, diverged)
        if bool(ended.any()):
            self._reset(ended)
            self.physics.kinematics()
        self.sense()
        log = {f"Reward/{name}": value.mean() * self.dt for name, value in terms.items()}
        extras = {"time_outs": time_out & ~failed, "log": log}
        return self.get_observations(), reward, ended, extras

    def get_observations(self) -> Any:
        from tensordict import TensorDict

        actor, critic = self.observe()
        return TensorDict({"actor": actor, "critic": critic}, batch_size=[self.num_envs], device=self.device)

    def observe(self) -> tuple[torch.Tensor, torch.Tensor]:
        """(actor, critic): the actor's terms with noise, the sensed ones as ``sense`` last recorded them, as late
        as each world's latency; the critic's as they are (privileged)."""
        noise = self.task.randomisation.noise
        parts = {t.name: self._noisy(t, noise) for t in self.task.actor if not t.sensed}
        sensed = [t for t in self.task.actor if t.sensed]
        if sensed:
            late = self._history[(self._cursor - self.latency) % self._history.shape[0], self._rows]
            parts.update(zip((t.name for t in sensed), torch.split(late, self._widths, dim=-1)))
        actor = torch.cat([parts[t.name] for t in self.task.actor], dim=-1)
        critic = torch.cat([_flat(t.fn(self)) for t in self.task.critic], dim=-1)
        return actor, critic

    def sense(self) -> None:
        """Record this control period's sensed terms (with their noise) in the latency buffer; a world just reset
        fills its whole history with them (no reading from before its episode)."""
        sensed = [self._noisy(t, self.task.randomisation.noise) for t in self.task.actor if t.sensed]
        if not sensed:
            return
        value = torch.cat(sensed, dim=-1)
        depth = self.task.randomisation.latency[1] + 1
        if self._history is None:
            self._history = value.unsqueeze(0).repeat(depth, 1, 1)
            self._widths = [part.shape[1] for part in sensed]
            self._rows = torch.arange(self.num_envs, device=self.device)
        self._cursor = (self._cursor + 1) % depth
        self._history[self._cursor] = value
        fresh = self._fresh.view(1, -1, 1)
        self._history.copy_(torch.where(fresh, value.unsqueeze(0).expand_as(self._history), self._history))
        self._fresh = torch.zeros_like(self._fresh)

    def observation_sizes(self) -> tuple[int, int]:
        """(actor, critic) observation widths, computed without drawing noise."""
        return tuple(sum(_flat(t.fn(self)).shape[1] for t in terms) for terms in (self.task.actor, self.task.critic))

    def _noisy(self, term: Obs, scale: float) -> torch.Tensor:
        value = _flat(term.fn(self))
        if term.noise > 0 and scale > 0:
            width = term.noise * scale
            value = value + (2 * torch.rand(value.shape, generator=self.generator, device=self.device) - 1) * width
        return value

    def close(self) -> None:
        """Nothing held beyond memory."""


class EpisodeStats:
    """Running sums over ended episodes, on the device (read once per iteration: no sync per step)."""

    def __init__(self, device: Any) -> None:
        self.device = device
        self.clear()

    def clear(self) -> None:
        zero = torch.zeros((), device=self.device)
        self.episodes, self.successes, self.failures, self.diverged = (zero.clone() for _ in range(4))
        self.score, self.scored = zero.clone(), zero.clone()

    def add(
        self, env: TaskEnv, ended: torch.Tensor, failed: torch.Tensor, reward: torch.Tensor, diverged: torch.Tensor
    ) -> None:
        won = env.task.success(env).bool() & ended & ~diverged
        self.diverged += diverged.sum()
        self.episodes += ended.sum()
        self.successes += won.sum()
        self.failures += failed.sum()
        if env.task.score is not None:
            # Over the episodes the physics kept: an unstable world's state (an object kilometres away, or not
            # finite) says nothing of the policy, and one such score would outweigh all the others.
            kept = ended & ~diverged
            self.score += torch.where(kept, env.task.score(env), 0.0).sum()
            self.scored += kept.sum()

    def read(self) -> dict[str, float]:
        n = float(self.episodes)
        if n == 0:
            return {"episodes": 0.0}
        return {
            "episodes": n,
            "success": float(self.successes) / n,
            "failure": float(self.failures) / n,
            "diverged": float(self.diverged) / n,
            "score": float(self.score) / float(self.scored) if float(self.scored) else float("nan"),
        }


def _flat(value: torch.Tensor) -> torch.Tensor:
    return value.reshape(value.shape[0], -1).to(torch.float32)


def _coupled_columns(m: Any, device: Any) -> list[tuple[int, int, tuple[float, ...]]]:
    """(qpos column of a coupled joint, its leader's index among the actuators, coefficients) per coupling."""
    from svhdesc.model import couplings

    actuated = [m.joint(int(m.actuator_trnid[a, 0])).name for a in range(m.nu)]
    result = []
    for c in couplings(m):
        if c.leader in actuated:
            result.append((int(m.joint(c.joint).qposadr[0]), actuated.index(c.leader), c.coeffs))
    return result


def _substeps(control_dt: float, physics_dt: float) -> int:
    n = control_dt / physics_dt
    if abs(n - round(n)) > 1e-6 or round(n) < 1:
        raise SvhdescError(f"control period {control_dt} s is not a whole number of physics steps of {physics_dt} s")
    return int(round(n))


def _channels() -> tuple[str, ...]:
    from svhdesc.model import DRIVER_CHANNELS

    return tuple(DRIVER_CHANNELS)
