"""How many worlds fit: ``train --envs`` refused, before anything is allocated, where they would not fit in memory.

A world costs its engine's state (MuJoCo C: one ``MjData``, its arena counted whole, as MuJoCo may fill it; Warp:
what ``make_data`` and ``put_model`` allocate per world, measured on the CPU with one world and two), the task's
own tensors (measured on one world in MuJoCo C), and PPO's: rsl-rl's rollout storage (``steps_per_env``
transitions of both observations, the action with the distribution's mean and deviation, five scalars) and the
update's mini-batch (the rows copied out of the storage, and the activations of both networks and their gradients).
A fifth of the memory is left for what no world owns (the interpreter, torch, MuJoCo, the networks). For svh_reach
on Warp's CPU a process grew by 134.7 kB a world over its first iteration, against 134.0 kB estimated
(tests/hostile/test_bounds.py).
"""

from __future__ import annotations

import contextlib
import dataclasses
import math
import os
from pathlib import Path
from typing import Any

from svhdesc.errors import SvhdescError
from svhdesc.learn.spec import Task

SHARE = 0.8  # of the memory available, what the worlds may take
FLOAT = 4  # bytes of a float32


@dataclasses.dataclass(frozen=True)
class WorldCost:
    """Bytes one world costs: its engine's state, the task's tensors, PPO's storage and update."""

    engine: int
    task: int
    learning: int

    @property
    def total(self) -> int:
        return self.engine + self.task + self.learning

    def describe(self) -> str:
        parts = (("engine", self.engine), ("task", self.task), ("PPO", self.learning))
        return f"{_size(self.total)} a world ({', '.join(f'{name} {_size(value)}' for name, value in parts)})"


def world_cost(task: Task, backend: str) -> WorldCost:
    """What one world of ``task`` costs on ``backend`` (a one-world MuJoCo C environment measures the task's part)."""
    from svhdesc.learn.env import TaskEnv

    probe = TaskEnv(task, 1, device="cpu", backend="mujoco")
    actor, critic = probe.observation_sizes()
    tensors = _tensor_bytes([*vars(probe).values(), *probe.commands.values(), *probe.nominal.values()])
    return WorldCost(_engine_bytes(task, probe, backend), tensors, _ppo_bytes(task, actor, critic, probe.num_actions))


def _engine_bytes(task: Task, probe: Any, backend: str) -> int:
    physics = probe.physics  # CPhysics: one MjData and the float32 stacks of one world
    stacks = sum(a.nbytes for group in (physics._state, physics._read, physics._params) for a in group.values())
    if backend == "mujoco":
        data = physics._datas[0]
        return int(data.nbuffer + data.narena) + stacks
    return _warp_bytes(probe.mjm, task.scene.nconmax, task.scene.njmax) + stacks


def _warp_bytes(mjm: Any, nconmax: int, njmax: int) -> int:
    """Bytes Warp allocates per world for ``mjm`` (two worlds less one, on the CPU: the sizes are the device's)."""
    from svhdesc.batch.device import quiet_init
    from svhdesc.extras import require
    from svhdesc.learn.physics import MODEL_FIELDS

    wp, mjw = require("warp", "svhdesc train", "rl"), require("mujoco_warp", "svhdesc train", "rl")
    quiet_init(wp)
    sizes = []
    with wp.ScopedDevice("cpu"):
        for nworld in (1, 2):
            model = mjw.put_model(mjm, batch_sizes=dict.fromkeys(MODEL_FIELDS, nworld))
            data = mjw.make_data(mjm, nworld=nworld, nconmax=nconmax, njmax=njmax)
            sizes.append(_array_bytes(wp, model, set()) + _array_bytes(wp, data, set()))
    return sizes[1] - sizes[0]


def _array_bytes(wp: Any, value: Any, seen: set[int]) -> int:
    if isinstance(value, wp.array):
        if id(value) in seen:
            return 0
        seen.add(id(value))
        return int(value.capacity)
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        return sum(_array_bytes(wp, getattr(value, f.name), seen) for f in dataclasses.fields(value))
    return 0


def _tensor_bytes(values: list[Any]) -> int:
    import torch

    return sum(v.element_size() * v.numel() for v in values if isinstance(v, torch.Tensor))


def _ppo_bytes(task: Task, actor: int, critic: int, actions: int) -> int:
    """A world's share of rsl-rl's rollout storage and of one update's mini-batch."""
    training = task.training
    row = FLOAT * (actor + critic + 3 * actions + 5) + 1  # observations, action/mean/std, 5 scalars, done
    hidden = sum(training.hidden)
    activations = FLOAT * 2 * (actor + critic + 2 * 2 * hidden + actions + 1)  # forward and backward, both nets
    per_update = math.ceil(training.steps_per_env / training.minibatches)
    return training.steps_per_env * row + per_update * (row + activations)


def available(device: str) -> tuple[int, str]:
    """Bytes free for the worlds of this process on ``device``, and where they are (for the error)."""
    if device.startswith("cuda"):
        import torch

        free, _ = torch.cuda.mem_get_info(torch.device(device))
        return int(free), f"free on {device}"
    ranks = max(1, int(os.getenv("LOCAL_WORLD_SIZE", "1")))  # torchrun's ranks on this machine share its memory
    share = f" (shared by {ranks} ranks)" if ranks > 1 else ""
    return _machine_memory() // ranks, f"available on this machine{share}"


def _machine_memory() -> int:
    """MemAvailable, or less where this process's cgroup allows less."""
    free = os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
    with contextlib.suppress(OSError, ValueError):
        for line in Path("/proc/meminfo").read_text().splitlines():
            if line.startswith("MemAvailable:"):
                free = int(line.split()[1]) * 1024
    with contextlib.suppress(OSError, ValueError):
        limit, used = (Path("/sys/fs/cgroup", name).read_text().strip() for name in ("memory.max", "memory.current"))
        if limit.isdigit():
            free = min(free, int(limit) - int(used))
    return max(0, free)


def check_envs(task: Task, count: int, device: str, backend: str) -> WorldCost:
    """``count`` worlds fit in SHARE of the memory ``device`` has free, or an SvhdescError stating what fits."""
    cost = world_cost(task, backend)
    free, where = available("cpu" if backend == "mujoco" else device)
    most = int(free * SHARE) // cost.total
    if count > most:
        raise SvhdescError(
            f"--envs {count}: {task.name} on {backend} needs about {cost.describe()}, "
            f"{_size(count * cost.total)} in all; {_size(free)} {where} hold at most {most} "
            f"({SHARE:.0%} of it: the rest is for what no world owns)"
        )
    return cost


def _size(count: float) -> str:
    units = ("B", "KiB", "MiB", "GiB", "TiB", "PiB")
    power = min(len(units) - 1, int(math.log(max(count, 1.0), 1024)))
    return f"{count / 1024**power:.1f} {units[power]}"
