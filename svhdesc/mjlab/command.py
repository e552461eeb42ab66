"""``svhdesc mjlab train|play TASK [--variant V] [mjlab's options]``: mjlab's own ``train`` and ``play`` on a task of
``svhdesc.mjlab``, with the task's robot taken from another built variant (a folder ``svhdesc build --out`` wrote,
or a shipped one). The task and the variant are checked first, each bad one an error line; then mjlab runs as its
CLI does, the variant handed to the task's registration through its environment variable. Imports no mjlab until
it runs it."""

from __future__ import annotations

import os
import sys
from pathlib import Path

from svhdesc.errors import SvhdescError

# Task id -> (module under svhdesc.mjlab, what its robot needs)
TASKS = {"Svh-Rotate": ("rotate", "hand"), "Ur5-Svh-Lift": ("lift", "hand and arm")}


def variant_env(task_id: str) -> str:
    """The environment variable naming the task's variant at registration (``SVHDESC_MJLAB_SVH_ROTATE``)."""
    return "SVHDESC_MJLAB_" + task_id.upper().replace("-", "_")


def check(task_id: str, variant: str | None) -> str | None:
    """The variant's folder for the task, or an SvhdescError: an unknown task, an unknown variant, one without a
    hand, one lacking a joint the task's default pose names (an arm for the lift)."""
    if task_id not in TASKS:
        raise SvhdescError(f"unknown task {task_id!r} (svhdesc's mjlab tasks: {', '.join(TASKS)})")
    if variant is None:
        return None
    from svhdesc.learn.tasks import lift, rotate
    from svhdesc.mjlab import entity

    facts = entity.built(variant)
    if facts.hand is None or not facts.hand.prefix:
        raise SvhdescError(f"variant {facts.model.name} has no hand: {task_id} needs an SVH")
    task = rotate.TASK if TASKS[task_id][0] == "rotate" else lift.TASK
    try:
        entity.pose(facts, task.actions.default)
    except SvhdescError as exc:
        raise SvhdescError(f"{exc}: {task_id} needs a {TASKS[task_id][1]}") from None
    return str(facts.model.directory)


def run(action: str, task_id: str, variant: str | None, args: tuple[str, ...]) -> None:
    """Check, then hand over to mjlab's ``train`` or ``play`` (``mjlab.scripts.train:main``, ``...play:main``)."""
    folder = check(task_id, variant)
    from svhdesc.extras import require

    require("mjlab", f"'svhdesc mjlab {action}'", "mjlab")
    if folder is not None:
        os.environ[variant_env(task_id)] = folder
    from importlib import import_module

    script = import_module(f"mjlab.scripts.{action}")
    sys.argv = [action, task_id, *args]
    script.main()


def registered_variant(task_id: str, default: str) -> str | Path:
    """The variant a task registers with: its environment variable's (set by ``svhdesc mjlab``), else ``default``."""
    return os.environ.get(variant_env(task_id)) or default
