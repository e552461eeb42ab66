"""``svhdesc train``: PPO from rsl-rl on a task's environment, with one progress line per iteration.

rsl-rl's ``OnPolicyRunner`` owns the algorithm, the models (observation normalisation inside them), TensorBoard
logging, checkpoints and multi-GPU training (torch.distributed under ``torchrun``). svhdesc drives its iterations
itself only to stop on a wall-clock budget and to print one line per iteration instead of rsl-rl's block; each
iteration is the runner's own: act, step, ``process_env_step``, ``compute_returns``, ``update``, ``logger.log``.
"""

from __future__ import annotations

import contextlib
import io
import math
import os
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from svhdesc.errors import SvhdescError
from svhdesc.extras import require
from svhdesc.learn.spec import Task, Training

CHECKPOINT_EVERY = 50  # iterations; and always at the end


def ppo_config(training: Training, seed: int = 0) -> dict[str, Any]:
    """rsl-rl 5's runner configuration for a task's training settings."""
    return {
        "seed": seed,
        "num_steps_per_env": training.steps_per_env,
        "save_interval": CHECKPOINT_EVERY,
        "obs_groups": {"actor": ["actor"], "critic": ["critic"]},
        "algorithm": {
            "class_name": "PPO",
            "num_learning_epochs": training.epochs,
            "num_mini_batches": training.minibatches,
            "clip_param": 0.2,
            "gamma": training.gamma,
            "lam": 0.95,
            "value_loss_coef": 1.0,
            "entropy_coef": training.entropy,
            "learning_rate": training.learning_rate,
            "max_grad_norm": 1.0,
            "schedule": "adaptive",
            "desired_kl": 0.01,
        },
        "actor": {
            "class_name": "MLPModel",
            "hidden_dims": list(training.hidden),
            "activation": "elu",
            "obs_normalization": True,
            "distribution_cfg": {"class_name": "GaussianDistribution", "init_std": training.init_noise},
        },
        "critic": {
            "class_name": "MLPModel",
            "hidden_dims": list(training.hidden),
            "activation": "elu",
            "obs_normalization": True,
        },
    }


def make_runner(env: Any, cfg: dict[str, Any], log_dir: Path | None) -> Any:
    """rsl-rl's OnPolicyRunner; under torchrun on the CPU, torch.distributed with gloo instead of its NCCL."""
    require("rsl_rl", "svhdesc train", "rl")
    from rsl_rl.runners import OnPolicyRunner as base

    class Runner(base):  # type: ignore[misc,valid-type]
        def _configure_multi_gpu(self) -> None:
            if self.device != "cpu" or int(os.getenv("WORLD_SIZE", "1")) == 1:
                super()._configure_multi_gpu()
                return
            import torch.distributed as dist

            # rsl-rl's own data-parallel scheme (broadcast at start, gradients averaged in buckets), on gloo
            self.gpu_world_size = int(os.environ["WORLD_SIZE"])
            self.gpu_local_rank = int(os.getenv("LOCAL_RANK", "0"))
            self.gpu_global_rank = int(os.getenv("RANK", "0"))
            self.is_distributed = True
            self.cfg["multi_gpu"] = {
                "global_rank": self.gpu_global_rank,
                "local_rank": self.gpu_local_rank,
                "world_size": self.gpu_world_size,
            }
            if not dist.is_initialized():
                dist.init_process_group(backend="gloo", rank=self.gpu_global_rank, world_size=self.gpu_world_size)

    with contextlib.redirect_stdout(io.StringIO()):  # rsl-rl prints both models' layers
        runner = Runner(env, cfg, log_dir=str(log_dir) if log_dir is not None else None, device=str(env.device))
    # rsl-rl's code-state store writes git/<repo>.diff, the status and diff of whichever repository holds the
    # installed rsl_rl (an unrelated one's uncommitted work), into every run folder: a run folder holds svhdesc's
    # own state only.
    runner.logger._store_code_state = no_code_state
    return runner


def no_code_state() -> list[str]:
    """No files of the code's state to store or upload."""
    return []


@dataclass(frozen=True)
class Progress:
    """One iteration's figures: env-steps so far (every rank's), wall seconds since the start, env-steps/s of the
    iteration, the returns of the last 100 episodes (rsl-rl's buffer), the episodes ended in it (EpisodeStats)."""

    iteration: int
    env_steps: int
    wall: float
    steps_per_s: float
    returns: list[float]
    episodes: dict[str, float]
    losses: dict[str, float]


def iterate(runner: Any, env: Any, obs: Any) -> tuple[Any, dict[str, float], float, float, list[float]]:
    """One PPO iteration as ``OnPolicyRunner.learn`` runs it: (obs, losses, collect s, learn s, episode returns)."""
    import torch

    alg, cfg = runner.alg, runner.cfg
    start = time.perf_counter()
    with torch.inference_mode():
        for _ in range(cfg["num_steps_per_env"]):
            actions = alg.act(obs)
            obs, rewards, dones, extras = env.step(actions.to(env.device))
            obs, rewards, dones = obs.to(runner.device), rewards.to(runner.device), dones.to(runner.device)
            alg.process_env_step(obs, rewards, dones, extras)
            runner.logger.process_env_step(rewards, dones, extras, None)
        collect = time.perf_counter() - start
        alg.compute_returns(obs)
    start = time.perf_counter()
    losses = alg.update()
    return obs, losses, collect, time.perf_counter() - start, list(runner.logger.rewbuffer)


@dataclass(frozen=True)
class Budget:
    """When training stops: a wall-clock deadline (monotonic s) and an iteration count, whichever comes first."""

    deadline: float
    limit: float

    @classmethod
    def of(cls, minutes: float | None, iterations: int | None) -> Budget:
        deadline = math.inf if minutes is None else time.monotonic() + 60.0 * minutes
        return cls(deadline, math.inf if iterations is None else iterations)

    def allows(self, done: int) -> bool:
        return done < self.limit and time.monotonic() < self.deadline


class Session:
    """One training run: rsl-rl's runner over ``env``, the counters, what rank 0 prints, logs and saves."""

    def __init__(self, task: Task, env: Any, out: Path, seed: int, say: Any, on_iteration: Any) -> None:
        self.task, self.env, self.out, self.say, self.on_iteration = task, env, out, say, on_iteration
        self.rank = int(os.getenv("RANK", "0"))
        self.cfg = ppo_config(task.training, seed)
        self.runner = make_runner(env, self.cfg, out if self.rank == 0 else None)
        self.batch = self.cfg["num_steps_per_env"] * env.num_envs * self.runner.gpu_world_size  # every rank's
        self.began, self.steps, self.done = time.monotonic(), 0, 0
        self.last: Path | None = None

    def start(self, resume: Path | None) -> None:
        from svhdesc.learn.checkpoint import load_checkpoint, restore

        runner = self.runner
        if resume is not None:
            infos = restore(runner, load_checkpoint(resume, self.task), resume, self.env)  # refuses another task's
            runner.current_learning_iteration += 1
            self.steps = infos.get("env_steps", 0)  # the count goes on, as the iterations' does
        if self.rank == 0:
            with contextlib.redirect_stdout(io.StringIO()):  # rsl-rl's console lines are not progress lines
                runner.logger.init_logging_writer()
        runner.alg.train_mode()
        if runner.is_distributed:
            runner.alg.broadcast_parameters()
        self.obs = self.env.get_observations().to(runner.device)

    def iteration(self, budget: Budget) -> None:
        from svhdesc.learn.checkpoint import save_checkpoint

        runner = self.runner
        it = runner.current_learning_iteration
        self.obs, losses, collect, learn, returns = iterate(runner, self.env, self.obs)
        self.env.physics.check_overflow()
        self.steps += self.batch
        self.done += 1
        episodes = self.env.stats.read()
        self.env.stats.clear()
        if self.rank == 0:
            with contextlib.redirect_stdout(io.StringIO()):  # TensorBoard scalars; its console block is not ours
                policy = runner.alg.get_policy()
                runner.logger.log(
                    it,
                    it - self.done + 1,
                    it + 1,
                    collect,
                    learn,
                    losses,
                    runner.alg.learning_rate,
                    policy.output_std,
                    None,
                )
            _scalars(runner.logger.writer, it, episodes)
            wall = time.monotonic() - self.began
            rate = self.batch / (collect + learn)
            self.say(progress_line(self.task, it, self.steps, wall, rate, returns, episodes, budget, self.done))
            if self.on_iteration is not None:
                self.on_iteration(Progress(it, self.steps, wall, rate, returns, episodes, losses))
            if it % CHECKPOINT_EVERY == 0:
                self.last = save_checkpoint(runner, self.out, self.task, self.env, self.steps)
        runner.current_learning_iteration = it + 1

    def finish(self) -> Path:
        from svhdesc.learn.checkpoint import export_onnx, save_checkpoint

        runner = self.runner
        runner.current_learning_iteration -= 1  # the last iteration run: the final checkpoint's number
        if runner.is_distributed:
            agreed = ranks_agree(runner)
            self.say(agreed) if self.rank == 0 else None
        if self.rank != 0:
            return self.out
        if self.last is None or self.last.name != f"model_{runner.current_learning_iteration}.pt":
            self.last = save_checkpoint(runner, self.out, self.task, self.env, self.steps)
        export_onnx(runner, self.last.parent / "policy.onnx", self.task, self.env)
        if runner.logger.writer is not None:
            runner.logger.writer.flush()
        return self.last


def train(
    task: Task,
    env: Any,
    out: Path,
    minutes: float | None,
    iterations: int | None,
    resume: Path | None = None,
    seed: int = 0,
    say: Any = print,
    on_iteration: Callable[[Progress], None] | None = None,
) -> Path:
    """Train until ``minutes`` of wall time or ``iterations`` (whichever ends first); return the last checkpoint.
    ``on_iteration`` receives each iteration's figures (benchmarks/learn_bench.py draws its curves from them)."""
    torch = require("torch", "svhdesc train", "rl")
    torch.manual_seed(seed)
    if env.device.type == "cpu" and "OMP_NUM_THREADS" not in os.environ:
        # The networks are small: on a CPU, torch's thread pool costs far more than it gives (the update of an
        # svh_reach iteration took 5 s with the default threads on a loaded 2-core machine, 0.1 s with one).
        torch.set_num_threads(1)
    session = Session(task, env, out, seed, say, on_iteration)
    session.start(resume)
    budget = Budget.of(minutes, iterations)
    while _go_on(session.runner, budget.allows(session.done)):
        session.iteration(budget)
    return session.finish()


def _go_on(runner: Any, mine: bool) -> bool:
    """Whether to run another iteration; under torchrun rank 0's clock decides for all (a rank that stopped alone
    would leave the others waiting in the gradient reduction)."""
    if not runner.is_distributed:
        return mine
    import torch
    import torch.distributed as dist

    flag = torch.tensor([1 if mine else 0])
    dist.broadcast(flag, src=0)
    return bool(flag.item())


def ranks_agree(runner: Any) -> str:
    """rsl-rl keeps the ranks' models equal (one broadcast, then averaged gradients): check it at the end."""
    import torch
    import torch.distributed as dist

    params = torch.cat([p.detach().flatten().double() for p in runner.alg.get_policy().parameters()])
    mine = torch.stack((params.sum(), (params * torch.arange(1, len(params) + 1, dtype=torch.float64)).sum()))
    everyone = [torch.zeros_like(mine) for _ in range(dist.get_world_size())]
    dist.all_gather(everyone, mine)
    if any(not torch.equal(other, everyone[0]) for other in everyone):
        raise SvhdescError(f"the {len(everyone)} ranks' actors differ after training (checksums {everyone})")
    return f"actor parameters identical on all {len(everyone)} ranks"


def _scalars(writer: Any, it: int, episodes: dict[str, float]) -> None:
    if writer is None or not episodes.get("episodes"):
        return
    writer.add_scalar("Episode/success", episodes["success"], it)
    writer.add_scalar("Episode/failure", episodes["failure"], it)
    writer.add_scalar("Episode/score", episodes["score"], it)


def progress_line(
    task: Task,
    it: int,
    steps: int,
    wall: float,
    rate: float,
    returns: list[float],
    episodes: dict[str, float],
    budget: Budget,
    done: int,
) -> str:
    reward = f"{sum(returns) / len(returns):.3f}" if returns else "-"
    left = []
    if budget.deadline < math.inf:
        left.append(max(0.0, budget.deadline - time.monotonic()))
    if budget.limit < math.inf:
        left.append(wall / done * (budget.limit - done))
    eta = min(left) if left else math.nan
    parts = [
        f"it {it}",
        f"env-steps {steps:,}",
        f"{rate:,.0f} env-steps/s ({rate / task.control_hz:,.1f} sim s/s)",
        f"return {reward}",
    ]
    if episodes.get("episodes"):
        parts.append(f"success {episodes['success']:.2f}")
        if task.score is not None:
            parts.append(f"{task.score_name} {episodes['score']:.3g}")
    parts.append(f"ETA {_clock(eta)}")
    return "  ".join(parts)


def _clock(seconds: float) -> str:
    if not math.isfinite(seconds):
        return "?"
    minutes, secs = divmod(int(round(seconds)), 60)
    return f"{minutes}m{secs:02d}s"


def check_device(device: str) -> None:
    """``--device cuda`` on a machine without one: an SvhdescError before anything is built or written."""
    torch = require("torch", "svhdesc train", "rl")
    if device.startswith("cuda") and not torch.cuda.is_available():
        raise SvhdescError(f"device {device!r}: no CUDA GPU on this machine (torch finds none): use --device cpu")
    if not (device == "cpu" or device.startswith("cuda")):
        raise SvhdescError(f"device {device!r}: use cpu, cuda or cuda:N")
