"""``svhdesc train`` and ``svhdesc play``: arguments checked before anything is built or written."""

from __future__ import annotations

import math
import os
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

from svhdesc.errors import SvhdescError
from svhdesc.learn.spec import Task
from svhdesc.learn.tasks import task as find_task

CPU_ENVS = 64  # the default --envs on the CPU


def _envs(task: Task, envs: int | None, device: str) -> int:
    count = envs if envs is not None else (task.training.envs if device.startswith("cuda") else CPU_ENVS)
    if count < 1:
        raise SvhdescError(f"--envs must be at least 1, not {count}")
    return count


def positive_seconds(option: str, value: float | None) -> None:
    """A duration the user gave: a positive, finite number (``inf`` would run forever, ``nan`` compares false)."""
    if value is not None and not 0 < value < math.inf:
        raise SvhdescError(f"{option} must be a positive, finite number, not {value}")


def check_seed(seed: int) -> None:
    """A seed torch and numpy take: a 64-bit integer (a larger one is an overflow traceback in torch)."""
    if not -(2**63) <= seed < 2**63 - 1024:  # room for the ranks' seed + rank
        raise SvhdescError(f"--seed must be a 64-bit integer, not {seed}")


def _budget(minutes: float | None, iterations: int | None) -> None:
    positive_seconds("--minutes", minutes)
    if iterations is not None and iterations < 1:
        raise SvhdescError(f"--iterations must be at least 1, not {iterations}")
    if minutes is None and iterations is None:
        raise SvhdescError("say how long to train: --minutes M or --iterations N")


def _out(task: Task, out: Path | None, resume: Path | None) -> Path:
    if resume is not None:
        return out if out is not None else resume.parent
    if out is None:
        return Path("runs") / task.name / time.strftime("%Y%m%d-%H%M%S")
    if out.exists() and (not out.is_dir() or any(out.iterdir())):
        raise SvhdescError(
            f"{out}: exists and is not an empty folder (a new run needs its own; --resume continues one)"
        )
    return out


def run_train(
    task_name: str,
    device: str,
    envs: int | None,
    minutes: float | None,
    iterations: int | None,
    backend: str,
    out: Path | None,
    resume: Path | None,
    seed: int,
    say: Callable[[str], None],
) -> Path:
    from svhdesc.learn.checkpoint import load_checkpoint
    from svhdesc.learn.env import TaskEnv
    from svhdesc.learn.memory import check_envs
    from svhdesc.learn.train import check_device, train

    task = find_task(task_name)
    count = _envs(task, envs, device)
    _budget(minutes, iterations)
    check_seed(seed)
    check_device(device)
    if backend == "mujoco" and device != "cpu":
        raise SvhdescError(f"--backend mujoco runs on the CPU, not on {device!r}")
    if resume is not None:
        load_checkpoint(resume, task)
    folder = _out(task, out, resume)
    check_envs(task, count, device, backend)  # before the worlds are allocated
    rank = int(os.getenv("RANK", "0"))  # under torchrun: each rank its own worlds and draws; rank 0 speaks
    if rank != 0:
        say = _silent
    env = TaskEnv(task, count, device=device, backend=backend, seed=seed + rank)
    say(
        f"training {task.name} ({task.summary}): {count} worlds on {device} ({backend}), "
        f"{task.control_hz:g} Hz control, {env.substeps} physics steps of {env.mjm.opt.timestep * 1000:g} ms each; "
        f"logs and checkpoints in {folder}"
    )
    last = train(task, env, folder, minutes, iterations, resume=resume, seed=seed, say=say)
    say(f"checkpoint {last}; policy {last.parent / 'policy.onnx'}")
    return last


def _silent(line: str) -> None:
    """Ranks other than 0 under torchrun print nothing: rank 0 speaks for the run."""


def policy_file(task: Task, checkpoint: Path, scratch: Path) -> Path:
    """An ONNX actor for ``checkpoint``: itself if it is one, else exported from the rsl-rl checkpoint."""
    from svhdesc.learn.checkpoint import export_onnx, load_checkpoint, onnx_info, restore

    if checkpoint.suffix == ".onnx":
        onnx_info(checkpoint, task)
        return checkpoint
    saved = load_checkpoint(checkpoint, task)
    from svhdesc.learn.env import TaskEnv
    from svhdesc.learn.train import make_runner, ppo_config

    env = TaskEnv(task, 1, device="cpu", backend="mujoco")
    runner = make_runner(env, ppo_config(task.training), None)
    restore(runner, saved, checkpoint, env)
    return export_onnx(runner, scratch / "policy.onnx", task, env)


def _play_counts(task: Task, frames: int, episodes: int, out: Path | None) -> None:
    """At least one episode (none only beside --out: the strip alone); at most one frame per control step of the
    episode the strip shows (more would repeat states, and 1e9 of them are gigabytes before the first step)."""
    steps = max(1, round(task.episode_s * task.control_hz))
    if not 1 <= frames <= steps:
        raise SvhdescError(f"--frames must be from 1 to {steps} (one per control step of an episode), not {frames}")
    if episodes < 0 or (episodes == 0 and out is None):
        raise SvhdescError(f"--episodes must be at least 1 (0 only with --out: the strip alone), not {episodes}")


def _picture_path(out: Path) -> None:
    """Where play's strip goes: a .png that is a regular file or nothing yet, in a folder or where one can be made;
    checked before any episode runs (a folder there failed after the episodes, blaming OpenGL)."""
    from svhdesc.learn.checkpoint import file_kind

    if out.suffix.lower() != ".png":
        raise SvhdescError(f"{out}: the strip of frames is a PNG file (name it .png)")
    if out.exists() and not out.is_file():
        raise SvhdescError(f"{out}: is {file_kind(out.stat().st_mode)}, not a file the strip can be written to")
    above = next((p for p in out.parents if p.exists()), None)
    if above is not None and not above.is_dir():
        raise SvhdescError(f"{out}: {above} is {file_kind(above.stat().st_mode)}, not a folder to write it in")


def run_play(
    task_name: str,
    checkpoint: Path,
    out: Path | None,
    frames: int,
    source: str,
    backend: str,
    episodes: int,
    seed: int,
    say: Callable[[str], None],
) -> dict[str, Any]:
    import tempfile

    from svhdesc.learn.env import TaskEnv
    from svhdesc.learn.play import draw, record, world_params
    from svhdesc.learn.policy import OnnxPolicy, evaluate

    task = find_task(task_name)
    _play_counts(task, frames, episodes, out)
    check_seed(seed)
    if out is not None:
        _picture_path(out)
    with tempfile.TemporaryDirectory() as scratch:
        policy = OnnxPolicy(policy_file(task, checkpoint, Path(scratch)), task)
        result: dict[str, Any] = {"task": task.name, "source": source, "backend": backend}
        if episodes:
            env = TaskEnv(task, min(episodes, CPU_ENVS), device="cpu", backend=backend, source=source, seed=seed)
            policy.check_fits(env)
            figures = evaluate(env, policy, episodes)
            result.update(episodes=figures.episodes, success=figures.success, score=figures.score)
            score = f", {task.score_name} {figures.score:.3g}" if figures.score is not None else ""
            say(
                f"{task.name} on the {source} model ({backend}): success {figures.success:.2f} "
                f"over {figures.episodes} episodes{score}"
            )
        if out is not None:
            env = TaskEnv(task, 1, device="cpu", backend=backend, source=source, seed=seed)
            policy.check_fits(env)
            params = world_params(env)
            states, shown = record(env, policy, frames)
            draw(task, source, params, states, out)
            result["picture"] = str(out)
            say(f"{out}: {len(states)} frames of one episode ({shown['steps']} control steps)")
    return result
