"""The tasks, by name. Each module declares one ``Task`` (``svhdesc.learn.spec``) as ``TASK``."""

from __future__ import annotations

from importlib import import_module

from svhdesc.errors import SvhdescError
from svhdesc.learn.spec import Task

# name -> module under svhdesc.learn.tasks
TASKS = {
    "svh_reach": "reach",
    "svh_rotate": "rotate",
    "svh_reorient": "reorient",
    "ur5_lift": "lift",
}


def task(name: str) -> Task:
    if name not in TASKS:
        raise SvhdescError(f"unknown task {name!r} (known: {', '.join(TASKS)})")
    return import_module(f"svhdesc.learn.tasks.{TASKS[name]}").TASK
