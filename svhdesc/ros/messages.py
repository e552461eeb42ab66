"""control_msgs' FollowJointTrajectory message classes, built at runtime with genpy.

Debian 12 does not package control_msgs. Its definitions live in ``definitions/``; the action is
expanded into its seven messages the way actionlib_msgs' genaction does, and every dependency's
text comes from the installed message classes, so the md5sums equal a real ROS system's.
"""

from __future__ import annotations

import functools
import importlib
from pathlib import Path
from types import SimpleNamespace
from typing import Any

from .system import import_ros

PACKAGE = "control_msgs"
DEFINITIONS = Path(__file__).resolve().parent / "definitions"
SEPARATOR = "\n" + "=" * 80 + "\n"
ACTION = "FollowJointTrajectory"


def _strip_comments(text: str) -> str:
    return "\n".join(line for line in text.splitlines() if not line.lstrip().startswith("#")) + "\n"


def _own_definitions() -> dict[str, str]:
    """Message texts of control_msgs/<name> for the action's seven messages and JointTolerance."""
    goal, result, feedback = _strip_comments((DEFINITIONS / f"{ACTION}.action").read_text()).split("---\n")
    name = ACTION
    return {
        "JointTolerance": _strip_comments((DEFINITIONS / "JointTolerance.msg").read_text()),
        f"{name}Goal": goal,
        f"{name}Result": result,
        f"{name}Feedback": feedback,
        f"{name}Action": f"{name}ActionGoal action_goal\n{name}ActionResult action_result\n"
        f"{name}ActionFeedback action_feedback\n",
        f"{name}ActionGoal": f"Header header\nactionlib_msgs/GoalID goal_id\n{name}Goal goal\n",
        f"{name}ActionResult": f"Header header\nactionlib_msgs/GoalStatus status\n{name}Result result\n",
        f"{name}ActionFeedback": f"Header header\nactionlib_msgs/GoalStatus status\n{name}Feedback feedback\n",
    }


def _installed_text(full_type: str) -> str:
    """The definition of an installed message type (e.g. trajectory_msgs/JointTrajectory)."""
    package, name = full_type.split("/")
    module = importlib.import_module(f"{package}.msg")
    return getattr(module, name)._full_text.split(SEPARATOR)[0]


def _field_types(text: str, package: str) -> list[str]:
    types = []
    for line in text.splitlines():
        words = line.split("#")[0].split()
        if len(words) < 2 or "=" in line.split("#")[0]:
            continue
        base = words[0].split("[")[0]
        if base == "Header":
            types.append("std_msgs/Header")
        elif "/" in base:
            types.append(base)
        elif base[0].isupper():
            types.append(f"{package}/{base}")
    return types


def catalogue(full_type: str, own: dict[str, str]) -> str:
    """``gendeps --cat`` style text of ``full_type``: its definition, then each dependency's.

    ``own`` maps full type names to definitions not installed here; the rest come from the
    installed message packages."""
    order: list[str] = []
    texts: dict[str, str] = {}

    def visit(name: str) -> None:
        texts[name] = own[name] if name in own else _installed_text(name)
        for dep in _field_types(texts[name], name.split("/")[0]):
            if dep not in texts:
                order.append(dep)
                visit(dep)

    visit(full_type)
    return texts[full_type] + "".join(f"{SEPARATOR}MSG: {dep}\n{texts[dep]}" for dep in order)


def message_catalogue(name: str) -> str:
    """The catalogue of control_msgs/<name>."""
    own = {f"{PACKAGE}/{k}": v for k, v in _own_definitions().items()}
    return catalogue(f"{PACKAGE}/{name}", own)


def dynamic_class(full_type: str, definition: str) -> Any:
    """A message class for ``full_type`` from its definition (dependencies from installed packages),
    e.g. tf2_msgs/TFMessage where python3-tf2-msgs is not installed."""
    import_ros()
    from genpy.dynamic import generate_dynamic

    return generate_dynamic(full_type, catalogue(full_type, {full_type: definition}))[full_type]


@functools.cache
def control_msgs() -> Any:
    """A namespace like ``control_msgs.msg``: the real package when installed, else generated."""
    import_ros()
    try:
        module = importlib.import_module("control_msgs.msg")
        return module
    except ImportError:
        pass
    from genpy.dynamic import generate_dynamic

    classes = {}
    for name in _own_definitions():
        generated = generate_dynamic(f"{PACKAGE}/{name}", message_catalogue(name))
        classes[name] = generated[f"{PACKAGE}/{name}"]
    # Nested fields must be instances of the same classes the parent was generated with.
    action = generate_dynamic(f"{PACKAGE}/{ACTION}Action", message_catalogue(f"{ACTION}Action"))
    for name in classes:
        if f"{PACKAGE}/{name}" in action:
            classes[name] = action[f"{PACKAGE}/{name}"]
    return SimpleNamespace(**classes)
