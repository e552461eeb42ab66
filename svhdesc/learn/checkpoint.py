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
import math
import os
import re
import stat
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
    os.fchmod(handle, 0o666 & ~_umask())  # mkstemp's 0600 would make a shared run folder's files the owner's alone
    os.close(handle)
    try:
        yield temporary
        os.replace(temporary, path)
    finally:
        if os.path.exists(temporary):
            os.unlink(temporary)


def _umask() -> int:
    """The process's umask (read by setting it, the one portable way, and set back at once)."""
    mask = os.umask(0o022)
    os.umask(mask)
    return mask


def regular_file(path: Path, what: str) -> None:
    """``path`` is a regular file (a symbolic link to one counts), or an SvhdescError saying what it is instead: a
    FIFO would block the read forever, a device never end it."""
    try:
        mode = path.stat().st_mode
    except FileNotFoundError:
        dangling = " (a symbolic link to a missing file)" if path.is_symlink() else ""
        raise SvhdescError(f"{path}: no such {what}{dangling}") from None
    except OSError as exc:  # a loop of links, a folder on the way that is not one, no permission
        raise SvhdescError(f"{path}: cannot be read as a {what} ({exc.strerror or exc})") from None
    if not stat.S_ISREG(mode):
        raise SvhdescError(f"{path}: not a regular file but {file_kind(mode)}, so not a {what}")


def file_kind(mode: int) -> str:
    """What a path is, in words (a file, a folder, a FIFO, ...)."""
    kinds = (
        (stat.S_ISREG, "a file"),
        (stat.S_ISDIR, "a folder"),
        (stat.S_ISFIFO, "a FIFO"),
        (stat.S_ISSOCK, "a socket"),
        (stat.S_ISCHR, "a character device"),
        (stat.S_ISBLK, "a block device"),
    )
    return next((name for test, name in kinds if test(mode)), "of an unknown kind")


def load_checkpoint(path: Path, task: Task) -> dict[str, Any]:
    """The checkpoint as rsl-rl saved it (the models' and the optimizer's state, ``iter``, svhdesc's ``infos``),
    loaded with ``weights_only=True``: tensors and plain containers only, so a crafted pickle runs no code (a
    checkpoint is a file people download and share). An SvhdescError naming the file if it is not an svhdesc
    checkpoint of ``task`` or holds a number that is not finite."""
    import pickle
    import warnings

    import torch

    regular_file(path, "checkpoint")
    try:
        with warnings.catch_warnings():  # torch's note on the pickle protocol is not the user's business
            warnings.simplefilter("ignore")
            saved = torch.load(str(path), weights_only=True, map_location="cpu")
    except pickle.UnpicklingError as exc:
        reason = _refused(exc)
        if "global" in reason.lower():  # an object or a call torch would have to make: code it will not run
            raise SvhdescError(f"{path}: refused: it holds more than weights and plain data ({reason})") from None
        raise SvhdescError(f"{path}: not a checkpoint ({reason})") from None
    except Exception as exc:  # torch raises many kinds for a file that is not a checkpoint
        raise SvhdescError(f"{path}: not a checkpoint ({type(exc).__name__}: {exc})") from None
    infos = saved.get("infos") if isinstance(saved, dict) else None
    if not isinstance(infos, dict) or "task" not in infos:
        raise SvhdescError(f"{path}: not an svhdesc checkpoint (no task in it)")
    if infos["task"] != task.name:
        raise SvhdescError(f"{path}: a checkpoint of task {infos['task']!r}, not of {task.name!r}")
    steps = infos.get("env_steps", 0)
    if type(steps) is not int or steps < 0:
        raise SvhdescError(f"{path}: env_steps {steps!r} in it is not a count")
    missing = [key for key in MODELS if not isinstance(saved.get(key), dict)]
    if missing or not isinstance(saved.get("iter"), int):
        raise SvhdescError(f"{path}: not an svhdesc checkpoint (no {(missing or ['iter'])[0]} in it)")
    where = _non_finite({key: saved[key] for key in MODELS})
    if where is not None:
        raise SvhdescError(f"{path}: {where} holds a number that is not finite (a diverged run's weights)")
    return saved


MODELS = ("actor_state_dict", "critic_state_dict", "optimizer_state_dict")  # rsl-rl's PPO.save


def _refused(exc: Exception) -> str:
    """What torch's weights-only unpickler refused, without its advice to load the file unsafely."""
    found = re.search(r"WeightsUnpickler error:\s*(.+?)(?:\. Please|\n|$)", str(exc))
    return found.group(1).strip() if found else type(exc).__name__


def _non_finite(value: Any, where: str = "") -> str | None:
    """The first entry (``actor_state_dict.mlp.0.weight``) holding a NaN or an infinity, else None."""
    import torch

    if isinstance(value, torch.Tensor):
        return where if value.is_floating_point() and not bool(torch.isfinite(value).all()) else None
    if isinstance(value, float):
        return None if math.isfinite(value) else where
    items = value.items() if isinstance(value, dict) else enumerate(value) if isinstance(value, list | tuple) else ()
    for key, item in items:
        found = _non_finite(item, f"{where}.{key}" if where else str(key))
        if found is not None:
            return found
    return None


def restore(runner: Any, saved: dict[str, Any], path: Path, env: Any) -> dict[str, Any]:
    """Load a checkpoint that ``load_checkpoint`` read into ``runner`` (its networks, optimizer and iteration:
    rsl-rl's own ``load`` would unpickle the file again, code and all); its infos. An SvhdescError naming the file
    if its networks do not fit ``env``'s observations and actions."""
    infos = saved["infos"]
    check_widths(path, infos, env)
    try:
        runner.alg.load(saved, None, strict=True)
    except (KeyError, RuntimeError, ValueError) as exc:  # state dicts of other shapes or names
        raise SvhdescError(f"{path}: its networks do not fit task {infos['task']!r} ({_first_line(exc)})") from None
    runner.current_learning_iteration = saved["iter"]
    return infos


def check_widths(path: Path, info: dict[str, Any], env: Any) -> None:
    """The widths ``info`` states (a checkpoint's or an ONNX actor's) are ``env``'s, or an SvhdescError naming the
    file: a policy of the task as it was before its observations changed is refused before it acts."""
    actor, critic = env.observation_sizes()
    widths = {"actor_obs": int(actor), "critic_obs": int(critic), "actions": int(env.num_actions)}
    for key, width in widths.items():
        if key in info and info[key] != width:
            raise SvhdescError(f"{path}: {key} {info[key]!r} in it, the task's environment has {width}")


def _first_line(exc: Exception) -> str:
    text = str(exc).strip()
    return text.splitlines()[0] if text else type(exc).__name__


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
    naming the file if it is not one of ``task``, or its metadata is not what svhdesc writes (a JSON object whose
    widths are the model's input and output)."""
    from svhdesc.extras import require

    ort = require("onnxruntime", "running an exported policy", "policy")
    regular_file(path, "policy file")
    try:
        session = ort.InferenceSession(str(path), providers=["CPUExecutionProvider"])
    except Exception as exc:  # onnxruntime's own error kinds for a file that is not a model
        raise SvhdescError(f"{path}: not an ONNX model ({type(exc).__name__})") from None
    meta = session.get_modelmeta().custom_metadata_map
    if "svhdesc" not in meta:
        raise SvhdescError(f"{path}: an ONNX model without svhdesc's metadata (not exported by svhdesc train)")
    info = _metadata(path, meta["svhdesc"])
    if info.get("task") != task.name:
        raise SvhdescError(f"{path}: a policy of task {info.get('task')!r}, not of {task.name!r}")
    _check_ports(path, session, info)
    return info


def _metadata(path: Path, text: str) -> dict[str, Any]:
    """svhdesc's metadata of an ONNX actor: a JSON object with the actor's widths as positive integers."""
    try:
        info = json.loads(text)
    except ValueError as exc:  # JSONDecodeError, and the recursion of a hostile nesting
        raise SvhdescError(f"{path}: svhdesc's metadata in it is not JSON ({exc})") from None
    except RecursionError:
        raise SvhdescError(f"{path}: svhdesc's metadata in it is nested too deep to read") from None
    if not isinstance(info, dict):
        raise SvhdescError(f"{path}: svhdesc's metadata in it is not a JSON object but {type(info).__name__}")
    return info


def _check_ports(path: Path, session: Any, info: dict[str, Any]) -> None:
    """The model takes ``obs`` [batch, actor_obs] and gives ``actions`` [batch, actions], as its metadata says."""
    ports = {"obs": (session.get_inputs(), "actor_obs"), "actions": (session.get_outputs(), "actions")}
    for name, (found, key) in ports.items():
        width = info.get(key)
        if type(width) is not int or width < 1:
            raise SvhdescError(f"{path}: svhdesc's metadata in it has no positive integer {key} (it has {width!r})")
        port = next((p for p in found if p.name == name), None)
        if port is None:
            raise SvhdescError(f"{path}: the model has no {name!r} (it has {', '.join(p.name for p in found)})")
        if len(port.shape) != 2 or port.shape[1] != width:
            raise SvhdescError(f"{path}: the model's {name!r} has shape {port.shape}, its metadata says {key} {width}")
