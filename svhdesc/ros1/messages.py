"""control_msgs' and controller_manager_msgs' classes the node uses, built at runtime with genpy.

Debian 12 packages neither. Their definitions live in ``definitions/``; the action is expanded into
its seven messages the way actionlib_msgs' genaction does, services into Request/Response classes
with genmsg's service md5sum, and every dependency's text comes from the installed message
classes, so the md5sums equal a real ROS system's.
"""

from __future__ import annotations

import functools
import hashlib
import importlib
from pathlib import Path
from types import SimpleNamespace
from typing import Any

from svhdesc.ros1.system import import_ros

PACKAGE = "control_msgs"
DEFINITIONS = Path(__file__).resolve().parent / "definitions"
SEPARATOR = "\n" + "=" * 80 + "\n"
ACTION = "FollowJointTrajectory"


def _strip_comments(text: str) -> str:
    return "\n".join(line for line in text.splitlines() if not line.lstrip().startswith("#")) + "\n"


def _own_definitions() -> dict[str, str]:
    """Message texts of control_msgs/<name>: the action's seven messages, JointTolerance and
    JointTrajectoryControllerState."""
    goal, result, feedback = _strip_comments((DEFINITIONS / f"{ACTION}.action").read_text()).split("---\n")
    name = ACTION
    return {
        "JointTolerance": _strip_comments((DEFINITIONS / "JointTolerance.msg").read_text()),
        "JointTrajectoryControllerState": _strip_comments(
            (DEFINITIONS / "JointTrajectoryControllerState.msg").read_text()
        ),
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


BUILTIN_TYPES = {
    "bool", "byte", "char", "int8", "uint8", "int16", "uint16", "int32", "uint32", "int64", "uint64",
    "float32", "float64", "string", "time", "duration",
}  # fmt: skip


def md5_text(text: str, package: str, md5_of: Any) -> str:
    """genmsg's md5 text of a message definition: constants, then fields, nested types by their md5."""
    constants, fields = [], []
    for line in text.splitlines():
        body = line.split("#")[0].strip()
        if not body:
            continue
        kind, rest = body.split(None, 1)
        if "=" in rest:
            name, value = rest.split("=", 1)
            constants.append(f"{kind} {name.strip()}={value.strip()}")
            continue
        base = kind.split("[")[0]
        if base in BUILTIN_TYPES:
            fields.append(f"{kind} {rest.strip()}")
        else:
            full = "std_msgs/Header" if base == "Header" else base if "/" in base else f"{package}/{base}"
            fields.append(f"{md5_of(full)} {rest.strip()}")
    return "\n".join(constants + fields)


def _service(package: str, name: str, text: str, own: dict[str, str]) -> type:
    """A service class (``_type``, ``_md5sum``, ``_request_class``, ``_response_class``) as genpy makes."""
    from genpy.dynamic import generate_dynamic

    request, response = _strip_comments(text).split("---\n")
    own = {**own, f"{package}/{name}Request": request, f"{package}/{name}Response": response}
    classes = {}
    for part in ("Request", "Response"):
        full = f"{package}/{name}{part}"
        classes[part] = generate_dynamic(full, catalogue(full, own))[full]

    def md5_of(full: str) -> str:
        if full in own:
            return generate_dynamic(full, catalogue(full, own))[full]._md5sum
        package_name, message = full.split("/")
        return getattr(importlib.import_module(f"{package_name}.msg"), message)._md5sum

    digest = hashlib.md5((md5_text(request, package, md5_of) + md5_text(response, package, md5_of)).encode())
    service = type(
        name,
        (),
        {
            "_type": f"{package}/{name}",
            "_md5sum": digest.hexdigest(),
            "_request_class": classes["Request"],
            "_response_class": classes["Response"],
        },
    )
    for part in ("Request", "Response"):
        classes[part]._service_class = service  # as genpy's generated modules do
    return service


def real_package(package: str, probe: str) -> SimpleNamespace | None:
    """An installed ROS 1 package's ``msg`` and ``srv`` classes in one namespace, or None when it is
    absent or not genpy's (a ROS 2 package of the same name has no ``_md5sum``). Only public names are
    merged: both modules have ``__name__`` and the like."""
    try:
        modules = [importlib.import_module(f"{package}.{kind}") for kind in ("msg", "srv")]
    except ImportError:
        return None
    if not hasattr(getattr(modules[0], probe, None), "_md5sum"):
        return None
    names: dict[str, Any] = {}
    for module in modules:
        names.update({k: v for k, v in vars(module).items() if not k.startswith("_")})
    return SimpleNamespace(**names)


@functools.cache
def control_msgs() -> Any:
    """A namespace like ``control_msgs.msg`` + ``control_msgs.srv``: the real packages when
    installed, else generated."""
    import_ros()
    real = real_package("control_msgs", "FollowJointTrajectoryAction")
    if real is not None:
        return real
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
    query = _service(PACKAGE, "QueryTrajectoryState", (DEFINITIONS / "QueryTrajectoryState.srv").read_text(), {})
    classes.update(
        QueryTrajectoryState=query,
        QueryTrajectoryStateRequest=query._request_class,
        QueryTrajectoryStateResponse=query._response_class,
    )
    return SimpleNamespace(**classes)


MANAGER_PACKAGE = "controller_manager_msgs"


@functools.cache
def controller_manager_msgs() -> Any:
    """controller_manager_msgs' ControllerState and its services ListControllers,
    ListControllerTypes, SwitchController (the real package when installed, else generated)."""
    import_ros()
    names = ("ListControllers", "ListControllerTypes", "SwitchController")
    real = real_package(MANAGER_PACKAGE, "ControllerState")
    if real is not None:
        return real
    folder = DEFINITIONS / MANAGER_PACKAGE
    own = {
        f"{MANAGER_PACKAGE}/{n}": _strip_comments((folder / f"{n}.msg").read_text())
        for n in ("ControllerState", "HardwareInterfaceResources")
    }
    classes: dict[str, Any] = {}
    for name in names:
        service = _service(MANAGER_PACKAGE, name, (folder / f"{name}.srv").read_text(), own)
        classes.update({name: service, f"{name}Request": service._request_class})
        classes[f"{name}Response"] = service._response_class
    # ControllerState instances must be of the class ListControllersResponse was generated with.
    response = classes["ListControllersResponse"]
    state = response._slot_types and _nested(response, "controller")
    resources = _nested(state, "claimed_resources")
    classes.update(ControllerState=state, HardwareInterfaceResources=resources)
    return SimpleNamespace(**classes)


def _nested(message_class: Any, field: str) -> Any:
    """The class genpy generated for the (array) field ``field`` of ``message_class``."""
    import sys

    kind = message_class._slot_types[message_class.__slots__.index(field)].split("[")[0]
    module = sys.modules[message_class.__module__]
    return getattr(module, f"_{kind.replace('/', '__')}")
