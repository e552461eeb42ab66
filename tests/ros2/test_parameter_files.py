"""The generated ros2_controllers.yaml read by ROS 2's own parameter-file parser (rcl_yaml_param_parser, the C
library rcl uses for ``--ros-args --params-file``; from the Jazzy wheels, called through ctypes), and each value's
type held to what the controller manager and joint_trajectory_controller declare (ROS 2 refuses an override of
another type: an integer ``action_monitor_rate`` would stop the controller from configuring).

Runs in .venv-ros2; skips where the library is missing. Reads the committed generated/ files.
Seeded faults (in the test): ``action_monitor_rate: 20`` and a ``goal_time`` without ``.0`` are reported as
integers; a tab-indented file is refused by the parser.
"""

from __future__ import annotations

import ctypes
import sys
from pathlib import Path

import pytest

from tests.support import REPO, VARIANTS

LIBRARY = Path(sys.prefix) / "lib" / "librcl_yaml_param_parser.so"
if not LIBRARY.is_file():
    pytest.skip("rcl_yaml_param_parser (ROS 2 wheels) missing", allow_module_level=True)

# What each parameter is declared as: controller_manager's update_rate and <controller>.type; JTC's
# (joint_trajectory_controller_parameters.yaml). Constraint tolerances are doubles.
TYPES = {
    "update_rate": "integer",
    "type": "string",
    "joints": "string_array",
    "command_interfaces": "string_array",
    "state_interfaces": "string_array",
    "allow_partial_joints_goal": "bool",
    "action_monitor_rate": "double",
}


class Allocator(ctypes.Structure):
    _fields_ = [(name, ctypes.c_void_p) for name in ("allocate", "deallocate", "reallocate", "zero_allocate", "state")]


class StringArray(ctypes.Structure):
    _fields_ = [("size", ctypes.c_size_t), ("data", ctypes.POINTER(ctypes.c_char_p)), ("allocator", Allocator)]


class Variant(ctypes.Structure):
    _fields_ = [
        ("bool_value", ctypes.POINTER(ctypes.c_bool)),
        ("integer_value", ctypes.POINTER(ctypes.c_int64)),
        ("double_value", ctypes.POINTER(ctypes.c_double)),
        ("string_value", ctypes.c_char_p),
        ("byte_array_value", ctypes.c_void_p),
        ("bool_array_value", ctypes.c_void_p),
        ("integer_array_value", ctypes.c_void_p),
        ("double_array_value", ctypes.c_void_p),
        ("string_array_value", ctypes.POINTER(StringArray)),
    ]


class NodeParams(ctypes.Structure):
    _fields_ = [
        ("parameter_names", ctypes.POINTER(ctypes.c_char_p)),
        ("parameter_values", ctypes.POINTER(Variant)),
        ("num_params", ctypes.c_size_t),
        ("capacity_params", ctypes.c_size_t),
    ]


class Params(ctypes.Structure):
    _fields_ = [
        ("node_names", ctypes.POINTER(ctypes.c_char_p)),
        ("params", ctypes.POINTER(NodeParams)),
        ("num_nodes", ctypes.c_size_t),
        ("capacity_nodes", ctypes.c_size_t),
        ("allocator", Allocator),
    ]


def _value(variant: Variant) -> tuple[str, object]:
    for kind in ("bool", "integer", "double"):
        pointer = getattr(variant, f"{kind}_value")
        if pointer:
            return kind, pointer.contents.value
    if variant.string_value is not None:
        return "string", variant.string_value.decode()
    if variant.string_array_value:
        array = variant.string_array_value.contents
        return "string_array", [array.data[i].decode() for i in range(array.size)]
    return "other", None


def parse(path: Path) -> dict[str, dict[str, tuple[str, object]]] | None:
    """node -> parameter (dotted) -> (type, value), as rcl reads the file; None where rcl refuses it."""
    rcutils = ctypes.CDLL(str(LIBRARY.with_name("librcutils.so")))
    rcutils.rcutils_get_default_allocator.restype = Allocator
    parser = ctypes.CDLL(str(LIBRARY))
    parser.rcl_yaml_node_struct_init.restype = ctypes.POINTER(Params)
    parser.rcl_yaml_node_struct_init.argtypes = [Allocator]
    parser.rcl_parse_yaml_file.argtypes = [ctypes.c_char_p, ctypes.POINTER(Params)]
    parser.rcl_parse_yaml_file.restype = ctypes.c_bool
    parser.rcl_yaml_node_struct_fini.argtypes = [ctypes.POINTER(Params)]
    params = parser.rcl_yaml_node_struct_init(rcutils.rcutils_get_default_allocator())
    try:
        if not parser.rcl_parse_yaml_file(str(path).encode(), params):
            rcutils.rcutils_reset_error()
            return None
        found: dict[str, dict[str, tuple[str, object]]] = {}
        contents = params.contents
        for n in range(contents.num_nodes):
            node = contents.params[n]
            names = (node.parameter_names[i].decode() for i in range(node.num_params))
            values = (_value(node.parameter_values[i]) for i in range(node.num_params))
            found[contents.node_names[n].decode()] = dict(zip(names, values))
        return found
    finally:
        parser.rcl_yaml_node_struct_fini(params)


def type_errors(parameters: dict[str, dict[str, tuple[str, object]]]) -> list[str]:
    errors = []
    for node, values in parameters.items():
        for name, (kind, _) in values.items():
            leaf = name.rsplit(".", 1)[-1]
            expected = "double" if name.startswith("constraints.") else TYPES.get(leaf, "double")
            if kind != expected:
                errors.append(f"{node}: {name} is {kind}, declared {expected}")
    return errors


@pytest.mark.parametrize("variant", VARIANTS)
def test_rcl_reads_the_controllers_file_with_the_declared_types(variant: str, tmp_path: Path) -> None:
    path = REPO / "generated" / variant / "ros2" / "config" / "ros2_controllers.yaml"
    parameters = parse(path)
    assert parameters is not None
    manager = parameters["controller_manager"]
    assert manager["update_rate"] == ("integer", 125)
    assert manager["joint_state_broadcaster.type"][1] == "joint_state_broadcaster/JointStateBroadcaster"
    hand = "right_hand" if "right" in variant else "left_hand"
    assert parameters[hand]["joints"][1][0].endswith("_Hand_Thumb_Flexion")
    assert type_errors(parameters) == []
    # Seeded faults: integers where doubles are declared; a file rcl cannot read.
    text = path.read_text()
    broken = tmp_path / "broken.yaml"
    broken.write_text(text.replace("action_monitor_rate: 20.0", "action_monitor_rate: 20").replace(": 0.0", ": 0"))
    assert len(type_errors(parse(broken) or {})) >= 1
    broken.write_text(text.replace("  ros__parameters:", "\tros__parameters:", 1))
    assert parse(broken) is None
