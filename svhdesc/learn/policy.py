"""Running a trained actor: the exported ONNX file in onnxruntime (no torch needed to act), and episodes of a task
under it, counted the way training counts them (success, the task's score)."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from svhdesc.errors import SvhdescError
from svhdesc.extras import require
from svhdesc.learn.checkpoint import check_widths, onnx_info
from svhdesc.learn.spec import Task


class OnnxPolicy:
    """The actor of ``svhdesc train`` as exported (``policy.onnx``): observations [n, d] in, actions [n, a] out."""

    def __init__(self, path: Path, task: Task) -> None:
        self.path = path
        self.info = onnx_info(path, task)
        ort = require("onnxruntime", "running an exported policy", "rl")
        options = ort.SessionOptions()
        options.intra_op_num_threads = 1  # a small MLP: threads cost more than they give
        self.session = ort.InferenceSession(str(path), options, providers=["CPUExecutionProvider"])

    def __call__(self, obs: np.ndarray) -> np.ndarray:
        obs = np.asarray(obs, dtype=np.float32)
        if obs.ndim != 2 or obs.shape[1] != self.info["actor_obs"]:
            width = self.info["actor_obs"]
            raise SvhdescError(f"{self.path}: a policy of observations {width} wide, given shape {obs.shape}")
        return self.session.run(["actions"], {"obs": obs})[0]

    def check_fits(self, env: Any) -> None:
        """``env``'s observations and actions are as wide as the policy's, or an SvhdescError naming the file."""
        check_widths(self.path, self.info, env)


@dataclass
class Evaluation:
    episodes: int
    success: float
    score: float | None
    returns: float
    diverged: float = 0.0  # share of the episodes the physics ended (unstable), counted as failed


def evaluate(
    env: Any, act: Callable[[np.ndarray], np.ndarray], episodes: int, limit_steps: int | None = None
) -> Evaluation:
    """Run ``act`` (actor observations -> actions, numpy) in every world until ``episodes`` episodes have ended.

    Counts only the first ``episodes`` endings (worlds that end together are all counted)."""
    import torch

    env.stats.clear()
    obs = env.get_observations()["actor"]
    total = torch.zeros(env.num_envs, device=env.device)
    returns: list[float] = []
    steps = 0
    limit = limit_steps if limit_steps is not None else 4 * episodes * env.max_episode_length
    while float(env.stats.episodes) < episodes and steps < limit:
        action = torch.as_tensor(act(obs.cpu().numpy()), device=env.device)
        observations, reward, done, _ = env.step(action)
        obs = observations["actor"]
        total += reward
        if bool(done.any()):
            returns.extend(total[done].tolist())
            total[done] = 0.0
        steps += 1
    stats = env.stats.read()
    if not stats.get("episodes"):
        raise SvhdescError(f"no episode ended within {steps} control steps")
    score = stats["score"] if env.task.score is not None else None
    mean = float(np.mean(returns)) if returns else 0.0
    return Evaluation(int(stats["episodes"]), stats["success"], score, mean, stats["diverged"])


def zero_policy(width: int) -> Callable[[np.ndarray], np.ndarray]:
    """The untrained baseline: action 0, every target at the task's default pose."""
    return lambda obs: np.zeros((obs.shape[0], width), dtype=np.float32)
