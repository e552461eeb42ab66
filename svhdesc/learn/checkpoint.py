"""Checkpoints and the exported actor: what task they belong to, written atomically, read back with a clear error.

A checkpoint is rsl-rl's (``OnPolicyRunner.save``: models, optimizer, iteration) with svhdesc's ``infos``: the task,
its observation and action sizes, the env-steps taken. The ONNX actor (rsl-rl's export: normaliser and MLP, input
``obs``, output ``actions``) carries the same in its metadata, so ``play`` and the deployments refuse a policy of
another task and need no torch.
"""

from __future__ import annotations

import contextlib
import io
import json
import os
import tempfile
from collections.abc import Iterator
from pathlib import Path
from typing import Any

from svhdesc.errors import SvhdescError
from svhdesc.learn.spec import Task

FORMAT = 1


def policy_info(task: Task, env: Any, steps: int = 0) -> dict[str, Any]:
    actor, critic = env.observation_sizes()
    return {
        "format": FORMAT,
        "task": task.name,
        "actor_obs": int(actor),
        "critic_obs": int(critic),
        "actions": int(env.num_actions),
        "actuators": list(env.actuators),
        "control_hz": task.control_hz,
        "env_steps": int(steps),
    }


def save_checkpoint(runner: Any, out: Path, task: Task, env: Any, steps: int) -> Path:
    """``out/model_<iteration>.pt``, written to a temporary file in ``out`` and renamed into place."""
    out.mkdir(parents=True, exist_ok=True)
    path = out / f"model_{runner.current_learning_iteration}.pt"
    with replaced(path) as temporary:
        runner.save(temporary, infos=policy_info(task, env, steps))
    return path


@contextlib.contextmanager
def replaced(path: Path) -> Iterator[str]:
    """A temporary file beside ``path`` to write; renamed onto ``path`` if the block ends well, else removed."""
    handle, temporary = tempfile.mkstemp(dir=path.parent, prefix=f".{path.stem}-", suffix=path.suffix)
    os.close(handle)
    try:
        yield temporary
        os.replace(temporary, path)
    finally:
        if os.path.exists(temporary):
            os.unlink(temporary)


def read_checkpoint(path: Path, task: Task) -> dict[str, Any]:
    """The checkpoint's svhdesc infos; an SvhdescError naming the file if it is not a checkpoint of ``task``."""
    import torch

    if not path.is_file():
        raise SvhdescError(f"{path}: no such checkpoint")
    try:
        saved = torch.load(str(path), weights_only=False, map_location="cpu")
    except Exception as exc:  # torch raises many kinds for a file that is not a checkpoint
        raise SvhdescError(f"{path}: not a checkpoint ({type(exc).__name__}: {exc})") from None
    infos = saved.get("infos") if isinstance(saved, dict) else None
    if not isinstance(infos, dict) or "task" not in infos:
        raise SvhdescError(f"{path}: not an svhdesc checkpoint (no task in it)")
    if infos["task"] != task.name:
        raise SvhdescError(f"{path}: a checkpoint of task {infos['task']!r}, not of {task.name!r}")
    return infos


def export_onnx(runner: Any, path: Path, task: Task, env: Any) -> Path:
    """The actor as ONNX (rsl-rl's exportable module: normaliser and MLP; input ``obs`` [batch, n], output
    ``actions``, the batch size free), with the task's infos in the model's metadata, renamed into place."""
    import logging
    import warnings

    import onnx
    import torch

    module = runner.alg.get_policy().as_onnx(verbose=False).to("cpu").eval()
    dummy = torch.zeros(1, module.input_size)
    logging.getLogger("torch.onnx").setLevel(logging.ERROR)  # torchvision's absent operators, not ours
    with replaced(path) as temporary:
        with warnings.catch_warnings(), contextlib.redirect_stdout(io.StringIO()):  # its progress lines
            warnings.simplefilter("ignore")
            torch.onnx.export(
                module,
                (dummy,),
                temporary,
                input_names=["obs"],
                output_names=["actions"],
                opset_version=18,
                dynamic_shapes=({0: torch.export.Dim("batch")},),
                dynamo=True,
                external_data=False,  # one self-contained file (else the weights go beside it, under its name)
            )
        model = onnx.load(temporary)
        entry = model.metadata_props.add()
        entry.key, entry.value = "svhdesc", json.dumps(policy_info(task, env), sort_keys=True)
        onnx.save(model, temporary)
    return path


def onnx_info(path: Path, task: Task) -> dict[str, Any]:
    """An ONNX actor's svhdesc metadata (read with onnxruntime: deployment needs no onnx or torch); an SvhdescError
    if it is not one of ``task``."""
    from svhdesc.extras import require

    ort = require("onnxruntime", "running an exported policy", "policy")
    if not path.is_file():
        raise SvhdescError(f"{path}: no such policy file")
    try:
        session = ort.InferenceSession(str(path), providers=["CPUExecutionProvider"])
    except Exception as exc:  # onnxruntime's own error kinds for a file that is not a model
        raise SvhdescError(f"{path}: not an ONNX model ({type(exc).__name__})") from None
    meta = session.get_modelmeta().custom_metadata_map
    if "svhdesc" not in meta:
        raise SvhdescError(f"{path}: an ONNX model without svhdesc's metadata (not exported by svhdesc train)")
    info = json.loads(meta["svhdesc"])
    if info.get("task") != task.name:
        raise SvhdescError(f"{path}: a policy of task {info.get('task')!r}, not of {task.name!r}")
    return info
