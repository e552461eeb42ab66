"""Every bad input: exit 2, exactly one ``error:`` line naming the culprit, no traceback, output unchanged.

Runs the CLI in-process on a two-joint robot (tests/data/mini) so that each case costs milliseconds:
most fail before any mesh work.
"""

from __future__ import annotations

import shutil
import struct
import subprocess
from collections.abc import Callable, Iterator
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from svhdesc.cli import main
from tests.support import TESTS, fails_cleanly, run_cli, snapshot

MINI = TESTS / "data" / "mini"


@pytest.fixture(scope="module")
def good_build(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("mini-good") / "out"
    result = run_cli("build", "--config", str(MINI / "mini.yaml"), "--out", str(out), in_process=True)
    assert result.returncode == 0, result.stderr
    return out


@pytest.fixture
def mini(tmp_path: Path, project: Callable[..., Path], good_build: Path) -> tuple[Path, Path]:
    """(a copy of the mini sources, an --out holding their good build)."""
    copy = project("mini")
    out = tmp_path / "out"
    shutil.copytree(good_build, out)
    return copy, out


def edit(path: Path, old: str, new: str) -> None:
    text = path.read_text()
    assert old in text, f"{old!r} not in {path.name}"
    path.write_text(text.replace(old, new, 1))


def stl_with(value: float) -> bytes:
    """A binary STL tetrahedron with one coordinate set to ``value``."""
    corners = np.array([[0, 0, 0], [0.01, 0, 0], [0, 0.01, 0], [0, 0, 0.01]], dtype=float)
    corners[3, 2] = value
    faces = [(0, 2, 1), (0, 1, 3), (1, 2, 3), (0, 3, 2)]
    records = b"".join(
        struct.pack("<3f", 0, 0, 0) + b"".join(struct.pack("<3f", *corners[i]) for i in face) + b"\0\0"
        for face in faces
    )
    return b"x" * 80 + struct.pack("<I", len(faces)) + records


def flat_stl() -> bytes:
    tri = struct.pack("<3f", 0, 0, 0) + struct.pack("<9f", 0, 0, 0, 0.01, 0, 0, 0, 0.01, 0) + b"\0\0"
    tri2 = struct.pack("<3f", 0, 0, 0) + struct.pack("<9f", 0.01, 0, 0, 0.01, 0.01, 0, 0, 0.01, 0) + b"\0\0"
    return b"x" * 80 + struct.pack("<I", 2) + tri + tri2


Case = tuple[str, Callable[[Path], None], str]


def xacro(old: str, new: str) -> Callable[[Path], None]:
    return lambda p: edit(p / "finger.xacro", old, new)


def top_xacro(old: str, new: str) -> Callable[[Path], None]:
    return lambda p: edit(p / "mini.xacro", old, new)


def spec(old: str, new: str) -> Callable[[Path], None]:
    return lambda p: edit(p / "coupling.yaml", old, new)


def config(old: str, new: str) -> Callable[[Path], None]:
    return lambda p: edit(p / "mini.yaml", old, new)


def write(name: str, data: bytes) -> Callable[[Path], None]:
    return lambda p: (p / name).write_bytes(data)


def dae(old: str, new: str) -> Callable[[Path], None]:
    def change(p: Path) -> None:
        text = (p / "knuckle.dae").read_text()
        start = text.index('count="24">') + len('count="24">')
        first = text[start:].split()[0]
        if old == "first":
            text = text[:start] + new + text[start + len(first) :]
        else:
            text = text.replace(old, new, 1)
        (p / "knuckle.dae").write_text(text)

    return change


LIMIT = 'lower="0" upper="1.2"'
XACRO_CASES: list[Case] = [
    ("upper_nan", xacro(LIMIT, 'lower="0" upper="nan"'), "finger.xacro:"),
    ("upper_text", xacro(LIMIT, 'lower="0" upper="abc"'), "right_hand_A: upper"),
    ("upper_inf", xacro(LIMIT, 'lower="0" upper="inf"'), "non-finite"),
    ("origin_nan_expr", xacro('xyz="0 0 0.03"', "xyz=\"${float('nan')} 0 0.03\""), "finger.xacro:"),
    ("limits_reversed", xacro(LIMIT, 'lower="1.5" upper="1.2"'), "lower limit 1.5 is above"),
    ("joint_no_parent", xacro('<parent link="${prefix}_base"/>', ""), "needs <parent"),
    ("cylinder_no_radius", xacro('<box size="0.01 0.01 0.02"/>', '<cylinder length="0.02"/>'), "'radius'"),
    ("box_negative", xacro('<box size="0.01 0.01 0.02"/>', '<box size="0.01 -0.01 0.02"/>'), "must be > 0"),
    ("box_no_size", xacro('<box size="0.01 0.01 0.02"/>', "<box/>"), "needs a 'size'"),
    ("zero_axis", xacro('<axis xyz="1 0 0"/>', '<axis xyz="0 0 0"/>'), "zero joint axis"),
    ("duplicate_joint", xacro('name="${prefix}_j2"', 'name="${prefix}_A"'), "duplicate joint"),
    ("unknown_parent", xacro('<parent link="${prefix}_p"/>', '<parent link="nowhere"/>'), "'nowhere'"),
    ("joint_type", xacro('type="revolute"', 'type="floating"'), "'floating'"),
    ("negative_effort", xacro('effort="1" velocity="1"/>', 'effort="-1" velocity="1"/>'), "effort must be >= 0"),
    ("rgba_nan", xacro('rgba="0.5 0.5 0.5 1"', 'rgba="nan 0.5 0.5 1"'), "material grey"),
    ("malformed_xml", xacro('<link name="${prefix}_t">', "<link <"), "finger.xacro"),
    ("undefined_property", xacro('upper="1.0"', 'upper="${nope}"'), "nope"),
    ("missing_include", top_xacro('filename="finger.xacro"', 'filename="absent.xacro"'), "absent.xacro"),
    ("missing_mesh", top_xacro('filename="cube.stl"', 'filename="absent.stl"'), "absent.stl"),
    ("mesh_no_filename", top_xacro('<mesh filename="cube.stl"/>', "<mesh/>"), "needs a 'filename'"),
    ("scale_zero", xacro('scale="1 1 2"', 'scale="0 1 2"'), "bad scale"),
    ("scale_nan", xacro('scale="1 1 2"', 'scale="nan 1 2"'), "non-finite"),
    (
        "inertial_nan_mass",
        xacro(
            '<link name="${prefix}_t">', '<link name="${prefix}_t"><inertial><mass value="nan"/><inertia/></inertial>'
        ),
        "non-finite",
    ),
    (
        "inertial_no_mass",
        xacro('<link name="${prefix}_t">', '<link name="${prefix}_t"><inertial><inertia/></inertial>'),
        "needs <mass>",
    ),
    (
        "two_roots",
        xacro(
            '<parent link="${prefix}_p"/><child link="${prefix}_t"/>',
            '<parent link="${prefix}_p"/><child link="${prefix}_p"/>',
        ),
        "root link",
    ),
]

MESH_CASES: list[Case] = [
    ("stl_nan", write("cube.stl", stl_with(float("nan"))), "cube.stl"),
    ("stl_inf", write("cube.stl", stl_with(float("inf"))), "cube.stl"),
    ("stl_huge", write("cube.stl", stl_with(1e30)), "cube.stl"),
    ("stl_flat", write("cube.stl", flat_stl()), "flat"),
    ("stl_empty", write("cube.stl", b"x" * 80 + struct.pack("<I", 0)), "cube.stl"),
    ("stl_garbage", write("cube.stl", b"\xff\xfe garbage"), "cube.stl"),
    ("dae_nan", dae("first", "nan"), "knuckle.dae"),
    ("dae_inf", dae("first", "inf"), "knuckle.dae"),
    ("dae_huge", dae("first", "1e39"), "knuckle.dae"),
    ("dae_text", dae("first", "zero"), "knuckle.dae"),
    ("dae_malformed", dae("<library_geometries>", "<library_geometries"), "knuckle.dae"),
    ("dae_unit", dae('meter="1"', 'meter="-1"'), "knuckle.dae"),
]

SPEC_CASES: list[Case] = [
    ("poly_nan", spec("poly: [0.0, 0.5]", "poly: [0.0, .nan]"), "coupling.yaml:4"),
    ("poly_bool", spec("poly: [0.0, 0.5]", "poly: [0.0, true]"), "coupling.yaml:4"),
    ("poly_empty", spec("poly: [0.0, 0.5]", "poly: []"), "coupling.yaml:4"),
    ("poly_text", spec("poly: [0.0, 0.5]", "poly: half"), "poly"),
    ("effort_missing", spec(" effort: 1.0,", ""), "needs effort"),
    ("effort_text", spec("effort: 1.0", "effort: strong"), "effort"),
    ("effort_negative", spec("effort: 1.0", "effort: -1.0"), "effort must be > 0"),
    ("velocity_zero", spec("velocity: 1.0", "velocity: 0"), "velocity must be > 0"),
    ("range_three", spec("range: [0.0, 1.0]", "range: [0.0, 0.5, 1.0]"), "range must have 2 numbers"),
    ("range_reversed", spec("range: [0.0, 1.0]", "range: [1.0, 0.0]"), "empty range"),
    ("range_beyond_limit", spec("range: [0.0, 1.0]", "range: [0.0, 1.3]"), "leaves the limit"),
    (
        "couplings_scalar",
        spec("couplings:\n  - {joint: j2, follows: A, poly: [0.0, 0.5]}", "couplings: 5"),
        "'couplings' must be a list",
    ),
    ("channels_missing", spec("channels:", "channelz:"), "coupling.yaml"),
    ("unknown_follows", spec("follows: A", "follows: B"), "unknown channel B"),
    ("unknown_joint", spec("joint: j2", "joint: j9"), "right_hand_j9"),
    ("coupling_removed", spec("  - {joint: j2, follows: A, poly: [0.0, 0.5]}", ""), "joint right_hand_j2: is neither"),
    ("channel_unknown_key", spec("velocity: 1.0}", "velocity: 1.0, speed: 2}"), "speed"),
    ("spec_binary", write("coupling.yaml", b"\xff\xfe\x00\x01binary"), "coupling.yaml"),
    ("spec_duplicate_key", spec("poly: [0.0, 0.5]", "poly: [0.0, 0.5], joint: j2"), "duplicate key"),
]

CONFIG_CASES: list[Case] = [
    ("kp_text", config("kp: 1.0", "kp: stiff"), "mini.yaml:7: hand.kp must be a number"),
    ("kp_negative", config("kp: 1.0", "kp: -1.0"), "mini.yaml:7: hand.kp must be >= 0"),
    ("timestep_zero", config("timestep: 0.001", "timestep: 0"), "simulation.timestep must be > 0"),
    ("timestep_nan", config("timestep: 0.001", "timestep: .nan"), "simulation.timestep must be finite"),
    ("solref_one_value", config("coupling_solref: [0.002, 1.0]", "coupling_solref: [0.002]"), "coupling_solref"),
    ("limit_solref_negative", config("limit_solref: [0.002, 1.0]", "limit_solref: [-0.002, 1.0]"), "limit_solref"),
    ("friction_negative", config("sliding: 1.0", "sliding: -0.5"), "contact.sliding must be >= 0"),
    ("floor_text", config("floor_z: -0.1", "floor_z: low"), "scene.floor_z"),
    ("keyframe_beyond_limit", config("home: {A: 0.1}", "home: {A: 5.0}"), "keyframe home puts right_hand_A"),
    ("keyframe_text", config("home: {A: 0.1}", "home: {A: open}"), "keyframes.home.A"),
    ("keyframe_unknown_joint", config("home: {A: 0.1}", "home: {Z: 0.1}"), "unknown joint Z"),
    ("args_list", config("args: {side: right}", "args: [right]"), "'args' must map"),
    ("packages_list", config("coupling: coupling.yaml", "coupling: coupling.yaml\npackages: [a, b]"), "packages"),
    ("mass_unknown_link", config("  links: {}", "  links: {right_hand_x: 1.0}"), "no link right_hand_x"),
    (
        "inertial_unknown_link",
        config("  inertials: {}", "  inertials: {nolink: {mass: 1, com: [0, 0, 0], inertia: [1, 0, 0, 1, 0, 1]}}"),
        "no link nolink",
    ),
    (
        "inertial_short_com",
        config("  inertials: {}", "  inertials: {right_hand_t: {mass: 1, com: [0, 0], inertia: [1, 0, 0, 1, 0, 1]}}"),
        "com must have 3",
    ),
    (
        "inertial_nan_mass",
        config(
            "  inertials: {}", "  inertials: {right_hand_t: {mass: .nan, com: [0, 0, 0], inertia: [1, 0, 0, 1, 0, 1]}}"
        ),
        "mass must be finite",
    ),
    ("fingertip_unknown", config("fingertips: [t]", "fingertips: [t, zz]"), "no link right_hand_zz"),
    ("force_sensor_unknown", config("force_sensor: t", "force_sensor: zz"), "hand.force_sensor"),
    ("hand_unknown_key", config("kp: 1.0", "kp: 1.0\n  kpp: 2.0"), "unknown key(s) ['kpp'] in 'hand'"),
    (
        "budget_total_missing",
        config('{links: "{hand}_*", total: 0.1}', '{links: "{hand}_*"}'),
        "'mass.budgets[0].total' is required",
    ),
    ("budget_total_text", config("total: 0.1", "total: heavy"), "total must be a number"),
    (
        "extends_missing",
        config("coupling: coupling.yaml", "extends: absent.yaml\ncoupling: coupling.yaml"),
        "absent.yaml",
    ),
    ("contact_model", config("contact: {sliding: 1.0}", "contact: {model: sticky}"), "contact.model"),
    (
        "interface",
        config("contact: {sliding: 1.0}", "contact: {sliding: 1.0}\ntransmissions: {interface: voltage}"),
        "transmissions.interface",
    ),
    ("hand_scalar", config("scene: {floor_z: -0.1}", "scene: 5"), "'scene' must be a mapping"),
    ("noslip_fraction", config("timestep: 0.001", "timestep: 0.001\n  noslip_iterations: 1.5"), "noslip_iterations"),
    # The prefix is optional (a robot without a hand has none), but {hand} in a pattern needs it.
    (
        "hand_prefix_missing",
        config("  prefix: right_hand\n", ""),
        "mini.yaml:10: mass.budgets: '{hand}_*' names {hand}, but hand.prefix is not set",
    ),
    ("recompute_typo", config("  inertials: {}", "  inertials: recompute_all"), "mass.inertials must be a mapping"),
    (
        "recompute_no_source_inertial",
        config("  inertials: {}", "  inertials: {right_hand_t: recompute}"),
        "mini.yaml:13: mass.inertials.right_hand_t: recompute: link right_hand_t has no inertial in its source",
    ),
    (
        "xacro_python_missing",
        config("xacro: mini.xacro", "xacro: python:no_such_module_h3/a.urdf"),
        "no_such_module_h3",
    ),
    ("coupling_missing", config("coupling: coupling.yaml", "coupling: absent.yaml"), "absent.yaml"),
    ("unknown_top_key", config("collision: {mode: hull}", "collision: {mode: hull}\ncolision: {}"), "colision"),
    ("variant_unknown_key", config("args: {side: right}", "args: {side: right}\n    colour: red"), "colour"),
    ("yaml_binary", write("mini.yaml", b"\x89PNG\r\n\x1a\n\x00\xff"), "not a UTF-8"),
    ("yaml_syntax", config("variants:", "variants: [unclosed"), "mini.yaml:"),
    ("collision_mode", config("collision: {mode: hull}", "collision: {mode: magic}"), "magic"),
]

OBJ_NAN = "v nan 0 0\nv 0.01 0 0\nv 0 0.01 0\nv 0 0 0.01\nf 1 2 3\nf 1 3 4\nf 1 2 4\nf 2 3 4\n"
ASCII_STL_NAN = (
    "solid x\nfacet normal 0 0 1\nouter loop\nvertex nan 0 0\nvertex 1 0 0\nvertex 0 1 0\nendloop\nendfacet\nendsolid\n"
)


def obj_nan(project: Path) -> None:
    (project / "cube.obj").write_text(OBJ_NAN)
    edit(project / "mini.xacro", "cube.stl", "cube.obj")


def mesh_is_directory(project: Path) -> None:
    (project / "cube.stl").unlink()
    (project / "cube.stl").mkdir()


MORE_CASES: list[Case] = [
    ("origin_huge", xacro('xyz="0 0 0.03"', 'xyz="1e308 0 0.03"'), "implausibly large"),
    ("limit_huge", xacro('upper="1.0"', 'upper="1e308"'), "implausibly large"),
    (
        "self_include",
        xacro('<xacro:macro name="finger"', '<xacro:include filename="finger.xacro"/><xacro:macro name="finger"'),
        "finger.xacro",
    ),
    ("obj_nan", obj_nan, "cube.obj"),
    ("ascii_stl_nan", write("cube.stl", ASCII_STL_NAN.encode()), "cube.stl"),
    ("dae_bad_index", dae("<p>", "<p>99 "), "knuckle.dae"),
    ("mesh_is_directory", mesh_is_directory, "cube.stl"),
    ("poly_huge", spec("poly: [0.0, 0.5]", "poly: [0.0, 0.5, 1.0e+308]"), "poly must be within"),
    ("effort_huge", spec("effort: 1.0", "effort: 1.0e+308"), "effort must be <="),
    ("channel_name_number", spec("name: A", "name: 5"), "channel name"),
    ("spec_empty", write("coupling.yaml", b""), "coupling.yaml"),
    ("kp_huge", config("kp: 1.0", "kp: 1.0e+308"), "hand.kp must be within"),
    ("timestep_huge", config("timestep: 0.001", "timestep: 1.0e+308"), "simulation.timestep must be <="),
    ("budget_huge", config("total: 0.1", "total: 1.0e+308"), "total must be <="),
    (
        "solimp_out_of_range",
        config("coupling_solref: [0.002, 1.0]", "coupling_solref: [0.002, 1.0]\n  coupling_solimp: [0.9, 1.5, 0.001]"),
        "coupling_solimp",
    ),
    (
        "variant_null",
        config("  mini:\n    xacro: mini.xacro\n    args: {side: right}", "  mini: null"),
        "variant mini needs",
    ),
    ("keyframe_scalar", config("home: {A: 0.1}", "home: 5"), "keyframes.home must be a mapping"),
    ("budget_scalar", config('- {links: "{hand}_*", total: 0.1}', "- 5"), "mass.budgets[0]"),
    (
        "decompose_params_text",
        config("collision: {mode: hull}", "collision: {mode: decompose, params: {threshold: a}}"),
        "threshold",
    ),
    ("collision_classes_scalar", config("collision: {mode: hull}", "collision: {classes: 5}"), "collision.classes"),
    ("extends_itself", config("coupling: coupling.yaml", "extends: mini.yaml\ncoupling: coupling.yaml"), "loops back"),
    ("config_empty", write("mini.yaml", b""), "config must be a mapping"),
]


def two_fixed_joints_one_name(project: Path) -> None:
    """A fixed joint renamed to its sibling's name (the issue's f2 -> f1), in the macro."""
    fixed = (
        '    <link name="${prefix}_x"/><link name="${prefix}_y"/>\n'
        '    <joint name="${prefix}_f1" type="fixed"><parent link="${prefix}_t"/><child link="${prefix}_x"/></joint>\n'
        '    <joint name="${prefix}_f1" type="fixed"><parent link="${prefix}_x"/><child link="${prefix}_y"/></joint>\n'
    )
    edit(project / "finger.xacro", "  </xacro:macro>", fixed + "  </xacro:macro>")


DUPLICATE_CASES: list[Case] = [
    # file:line of the second element of the pair
    ("duplicate_fixed_joint", two_fixed_joints_one_name, "finger.xacro:24: duplicate joint 'right_hand_f1'"),
    (
        "duplicate_link",
        xacro('<link name="${prefix}_t">', '<link name="${prefix}_p">'),
        "finger.xacro:9: duplicate link",
    ),
    # An arm joint that is also a hand channel: two actuators (and transmissions) of one name.
    (
        "duplicate_actuator",
        config("scene: {floor_z: -0.1}", "scene: {floor_z: -0.1}\narm: {enabled: true, joints: [right_hand_A]}"),
        "mini.yaml:20: duplicate actuator name 'right_hand_A'",
    ),
]


def leaves_package(project: Path) -> None:
    """A mesh of package mini (the project's folder) named through '..' out of it: refused, never read."""
    edit(project / "mini.yaml", "coupling: coupling.yaml", "coupling: coupling.yaml\npackages: {mini: .}")
    edit(project / "mini.xacro", 'filename="cube.stl"', 'filename="package://mini/../../etc/passwd"')


# Issue 28: inputs that gave a traceback or named another place than the culprit.
HUGE = "9" * 400
CULPRIT_CASES: list[Case] = [
    ("poly_huge_integer", spec("poly: [0.0, 0.5]", f"poly: [0.0, {HUGE}]"), "coupling.yaml:4: coupled joint j2"),
    ("yaml_5000_digits", config("kp: 1.0", "kp: " + "9" * 5000), "mini.yaml:7: integer 9999"),
    ("yaml_nested_5000", config("kp: 1.0", "kp: " + "[" * 5000 + "]" * 5000), "mini.yaml:7: invalid YAML (nested"),
    ("spec_5000_digits", spec("effort: 1.0", "effort: " + "9" * 5000), "coupling.yaml:2: integer"),
    # an expression error inside the included finger.xacro names that file and line, not the entry file
    ("expression_in_include", xacro('upper="1.0"', 'upper="${1/0}"'), "finger.xacro:20: xacro: division by zero"),
    ("syntax_in_include", xacro('upper="1.0"', 'upper="${1 +* 2}"'), "finger.xacro:20: xacro: invalid syntax"),
    # a keyframe on a coupled joint (by its spec name), and a hand.prefix that begins no joint: the config's line
    (
        "keyframe_on_coupled_joint",
        config("home: {A: 0.1}", "home: {A: 0.1, j2: 0.05}"),
        "mini.yaml:21: keyframe home: j2 is a coupled joint; give its channel instead",
    ),
    ("hand_prefix_wrong", config("prefix: right_hand", "prefix: left_hand"), "mini.yaml:4: hand.prefix 'left_hand'"),
    (
        "arm_joint_typo",
        config("scene: {floor_z: -0.1}", "scene: {floor_z: -0.1}\narm: {enabled: true, joints: [right_hand_jx]}"),
        "mini.yaml:20: arm.joints: not in the robot: ['right_hand_jx']",
    ),
    # Issue 38: explicit inertials no engine takes, a macro that calls itself in an included file, a mesh URI that
    # climbs out of its package: each at the user's file and line.
    (
        "explicit_inertial_not_positive_definite",
        config(
            "  inertials: {}", "  inertials: {right_hand_t: {mass: 1, com: [0, 0, 0], inertia: [1, 0, 0, 1, 0, -1]}}"
        ),
        "mini.yaml:13: mass.inertials.right_hand_t: inertia not positive definite",
    ),
    (
        "explicit_inertial_triangle",
        config(
            "  inertials: {}", "  inertials: {right_hand_t: {mass: 1, com: [0, 0, 0], inertia: [1, 0, 0, 1, 0, 3]}}"
        ),
        "mini.yaml:13: mass.inertials.right_hand_t: principal moments [1. 1. 3.] violate the triangle inequality",
    ),
    (
        "macro_calls_itself_in_include",
        xacro('<link name="${prefix}_t">', '<xacro:finger prefix="${prefix}"/><link name="${prefix}_t">'),
        "finger.xacro:9: xacro: macro 'finger' calls itself (finger -> finger)",
    ),
    ("uri_leaves_its_package", leaves_package, "mini.xacro:6: link right_hand_base: package://mini/../../etc/passwd"),
]

ALL = [*XACRO_CASES, *MESH_CASES, *SPEC_CASES, *CONFIG_CASES, *MORE_CASES, *DUPLICATE_CASES, *CULPRIT_CASES]


@pytest.mark.parametrize(("name", "mutate", "match"), ALL, ids=[case[0] for case in ALL])
def test_bad_input_fails_cleanly(
    mini: tuple[Path, Path], name: str, mutate: Callable[[Path], None], match: str
) -> None:
    project, out = mini
    mutate(project)
    fails_cleanly(out, "build", "--config", str(project / "mini.yaml"), "--out", str(out), match=match)


def test_no_empty_out_is_left_behind(mini: tuple[Path, Path], tmp_path: Path) -> None:
    project, _ = mini
    edit(project / "coupling.yaml", "effort: 1.0", "effort: -1.0")
    fresh = tmp_path / "fresh" / "out"
    fails_cleanly(None, "build", "--config", str(project / "mini.yaml"), "--out", str(fresh), match="effort")
    assert not fresh.exists() and not fresh.parent.exists()


@pytest.mark.parametrize("command", ["list", "info", "validate"])
def test_other_subcommands_refuse_bad_config(mini: tuple[Path, Path], command: str) -> None:
    project, _ = mini
    edit(project / "mini.yaml", "kp: 1.0", "kp: stiff")
    args = {"list": ["list"], "info": ["info", "mini"], "validate": ["validate", "--checks", "limits"]}[command]
    fails_cleanly(None, *args, "--config", str(project / "mini.yaml"), match="hand.kp")


@pytest.mark.parametrize("command", ["build", "list", "validate"])
def test_missing_config_is_named(tmp_path: Path, command: str) -> None:
    missing = str(tmp_path / "missing.yaml")
    fails_cleanly(None, command, "--config", missing, match="missing.yaml")


def test_out_is_a_file(mini: tuple[Path, Path], tmp_path: Path) -> None:
    project, _ = mini
    target = tmp_path / "file"
    target.write_text("not a directory")
    fails_cleanly(None, "build", "--config", str(project / "mini.yaml"), "--out", str(target), match=str(target))
    fails_cleanly(None, "build", "--config", str(project / "mini.yaml"), "--out", str(target / "sub"), match="file")
    assert target.read_text() == "not a directory"


def _foreign(out: Path, kind: str) -> None:
    """Put in ``out/mini`` something svhdesc did not write there."""
    target = out / "mini"
    shutil.rmtree(target)
    if kind == "file":
        target.write_text("the user's notes")
    elif kind == "folder":
        target.mkdir()
        (target / "notes.txt").write_text("the user's notes")
    elif kind == "link":
        (out / "elsewhere").mkdir()
        target.symlink_to(out / "elsewhere")
    else:  # another variant's build, moved here
        shutil.copytree(out / "mini_other_source", target)
        shutil.rmtree(out / "mini_other_source")


@pytest.mark.parametrize("kind", ["file", "folder", "link", "another_variant"])
def test_a_path_under_out_svhdesc_did_not_write_is_refused(mini: tuple[Path, Path], kind: str) -> None:
    """Issue 38: OUT/<variant> that is a file, a link, a folder without its manifest or another variant's build is
    one error line and stays as it was (seeded fault: refuse_foreign not called: the file is deleted and replaced)."""
    project, out = mini
    if kind == "another_variant":
        shutil.copytree(out / "mini", out / "mini_other_source")
        manifest = out / "mini_other_source" / "manifest.json"
        manifest.write_text(manifest.read_text().replace('"variant": "mini"', '"variant": "other"'))
    _foreign(out, kind)
    config = ("--config", str(project / "mini.yaml"), "--out", str(out))
    fails_cleanly(out, "build", *config, "--force", match=f"{out / 'mini'}: ")
    fails_cleanly(out, "build", *config, match="refusing to replace it")


def test_bad_package_option_and_unknown_variant(mini: tuple[Path, Path]) -> None:
    project, out = mini
    base = ["build", "--config", str(project / "mini.yaml"), "--out", str(out)]
    fails_cleanly(out, *base, "--package", "nodir", match="nodir")
    fails_cleanly(out, *base, "nosuch", match="unknown variant 'nosuch'")


def test_non_utf8_config_path(tmp_path: Path) -> None:
    name = tmp_path / "caf\udce9.yaml"  # a file name that is not valid UTF-8
    fails_cleanly(None, "build", "--config", str(name), "--out", str(tmp_path / "out"), match="caf")


@pytest.fixture
def tmpfs(tmp_path: Path) -> Iterator[Callable[..., Path]]:
    """Mount a small tmpfs (needs root); skip where mounting is not allowed."""
    mounts: list[Path] = []

    def mount(size: str, name: str = "fs") -> Path:
        point = tmp_path / name
        point.mkdir()
        result = subprocess.run(
            ["mount", "-t", "tmpfs", "-o", f"size={size}", "tmpfs", str(point)], capture_output=True
        )
        if result.returncode != 0:
            pytest.skip("cannot mount a tmpfs here (needs root)")
        mounts.append(point)
        return point

    yield mount
    for point in reversed(mounts):
        subprocess.run(["umount", "-l", str(point)], check=False)


def test_disk_full(mini: tuple[Path, Path], tmpfs: Callable[..., Path]) -> None:
    project, _ = mini
    out = tmpfs("12k")
    message = fails_cleanly(
        out, "build", "--config", str(project / "mini.yaml"), "--out", str(out), match="no space left"
    )
    assert str(out) in message
    assert ".svhdesc-build-" not in message  # a staged file is named by where it goes, not by the staging folder
    assert list(out.iterdir()) == []  # no staging directory left behind


def test_read_only_out(mini: tuple[Path, Path], tmpfs: Callable[..., Path]) -> None:
    project, good = mini
    out = tmpfs("1m")
    shutil.copytree(good / "mini", out / "mini")
    subprocess.run(["mount", "-o", "remount,ro", str(out)], check=True)
    args = ["build", "--config", str(project / "mini.yaml"), "--out", str(out), "--force"]
    fails_cleanly(out, *args, match="Read-only file system")


# --- duplicate names: the issue's own case in the project's and the vendor's xacro, and the final model ---


@pytest.mark.parametrize("source", ["project", "vendor"])
def test_duplicate_fixed_joint_in_the_hand_xacro(tmp_path: Path, source: str) -> None:
    """The fixed joint f2 renamed to its sibling's name (palm_f1 here, f1 in the vendor's xacro)."""
    repo = MINI.parents[2]
    out = tmp_path / "out"
    shutil.copytree(repo / "generated" / "svh_right", out / "svh_right")
    if source == "project":
        project = tmp_path / "project"
        for part in ("config", "xacro"):
            shutil.copytree(repo / part, project / part)
        (project / "meshes").symlink_to(repo / "meshes")
        edit(project / "xacro" / "svh.xacro", 'name="f2"', 'name="palm_f1"')
        args = ["build", "svh_right", "--config", str(project / "config" / "svhdesc.yaml")]
        match = "svh.xacro:116: duplicate joint 'right_hand_palm_f1'"
    else:
        vendor = tmp_path / "schunk_svh_driver"
        shutil.copytree(repo.parent / "shared" / "vendor" / "schunk_svh_driver", vendor)
        edit(vendor / "description" / "urdf" / "svh.urdf.xacro", 'name="${name}_f2"', 'name="${name}_f1"')
        args = ["build", "svh_vendor_right", "--config", str(repo / "config" / "vendor.yaml")]
        args += ["--package", f"schunk_svh_driver={vendor}"]
        match = "svh.urdf.xacro:442: duplicate joint 'right_hand_f1'"
    fails_cleanly(out, *args, "--out", str(out), match=match)


@pytest.mark.parametrize("kind", ["link", "site", "sensor", "keyframe"])
def test_duplicate_names_in_the_final_model_are_refused(kind: str) -> None:
    """Names the stages add (sensor sites, keyframes) are checked in the final model, not only in the xacro."""
    from dataclasses import replace

    from svhdesc.compiler.stages.semantics import check_unique_names
    from svhdesc.core.settings.config import load_config
    from svhdesc.errors import SvhdescError
    from svhdesc.ir import ForceSensor, Keyframe, Link, Robot

    settings = load_config(MINI / "mini.yaml").select(["mini"])[0].settings
    robot = Robot(name="r", links=(Link("a"), Link("b")), joints=(), root="a")
    check_unique_names(robot, (settings.hand, settings.arm))  # distinct names pass
    twice = {
        "link": replace(robot, links=(Link("a"), Link("a"))),
        "site": replace(robot, sensors=(ForceSensor("a_force", "a"), ForceSensor("a_force", "b"))),
        "sensor": replace(robot, sensors=(ForceSensor("a_force", "a"), ForceSensor("a_force", "b"))),
        "keyframe": replace(robot, keyframes=(Keyframe("home", ()), Keyframe("home", ()))),
    }[kind]
    with pytest.raises(SvhdescError, match="duplicate (site|sensor|link|keyframe) name") as raised:
        check_unique_names(twice, (settings.hand, settings.arm))
    if kind in ("site", "sensor"):
        assert "mini.yaml:6" in str(raised.value)  # hand.force_sensor


# --- click's own usage errors, --jobs ---


def all_commands() -> list[list[str]]:
    import click

    paths: list[list[str]] = []

    def walk(group: click.Group, prefix: list[str]) -> None:
        for name, command in group.commands.items():
            paths.append([*prefix, name])
            if isinstance(command, click.Group):
                walk(command, [*prefix, name])

    walk(main, [])
    return paths


COMMANDS = [[], *all_commands()]


@pytest.mark.parametrize("command", COMMANDS, ids=[" ".join(c) or "svhdesc" for c in COMMANDS])
def test_usage_errors_are_one_line(command: list[str]) -> None:
    if command == ["sim"]:  # takes unknown options as ROS remappings; refuses them itself
        fails_cleanly(None, *command, "--bogus", match="unknown variant '--bogus'")
        return
    if command == ["mjlab"]:  # passes unknown options on to mjlab's CLI, after its action and task
        fails_cleanly(None, *command, "--bogus", match="'--bogus' is not one of 'train', 'play'")
        fails_cleanly(None, *command, "train", "--bogus", match="unknown task '--bogus'")
        return
    message = fails_cleanly(None, *command, "--bogus", match="No such option")
    assert "--bogus" in message and " ".join(["main", *command]) in message


@pytest.mark.parametrize(
    ("args", "match"),
    [
        (["build", "--jobs", "many"], "'many' is not a valid integer"),
        (["build", "-j", "-1"], "--jobs must be >= 0"),
        (["build", "-j", "-1", "--check"], "--jobs must be >= 0"),
        (["info"], "Missing argument 'VARIANT'"),
        (["nosuch"], "No such command 'nosuch'"),
        (["validate", "--samples", "0"], "--samples"),
    ],
)
def test_bad_option_values_are_one_line(mini: tuple[Path, Path], args: list[str], match: str) -> None:
    project, out = mini
    if args[0] == "build":
        args = [*args, "--config", str(project / "mini.yaml"), "--out", str(out)]
    fails_cleanly(out, *args, match=match)


def test_jobs_zero_means_one_per_cpu(mini: tuple[Path, Path]) -> None:
    project, out = mini
    args = ("build", "--config", str(project / "mini.yaml"), "--out", str(out), "--force", "-j", "0")
    result = run_cli(*args, in_process=True)
    assert result.returncode == 0, result.stderr
    assert "0 (the default): one per CPU" in CliRunner().invoke(main, ["build", "--help"]).output


@pytest.mark.parametrize("command", COMMANDS, ids=[" ".join(c) or "svhdesc" for c in COMMANDS])
def test_help_texts_are_click_s_own(command: list[str]) -> None:
    ours = CliRunner().invoke(main, [*command, "--help"])
    clicks = CliRunner().invoke(main, [*command, "--help"], standalone_mode=False)  # click's handling, untouched
    assert ours.exit_code == 0 and ours.output.startswith("Usage: main")
    assert ours.output == clicks.output


# --- paths that are not UTF-8 (Linux paths are bytes) ---

NOT_UTF8 = "caf\udce9"  # the byte 0xe9 alone, as Python names it


def test_config_in_a_non_utf8_folder_builds(tmp_path: Path, good_build: Path) -> None:
    project = tmp_path / NOT_UTF8 / "mini"
    shutil.copytree(MINI, project)
    out = tmp_path / "out"
    result = run_cli("build", "--config", str(project / "mini.yaml"), "--out", str(out), in_process=True)
    assert result.returncode == 0, result.stderr
    assert snapshot(out) == snapshot(good_build)  # the folder's name is in no output


def test_out_in_a_non_utf8_folder_builds(tmp_path: Path, good_build: Path) -> None:
    out = tmp_path / NOT_UTF8 / "out"
    result = run_cli("build", "--config", str(MINI / "mini.yaml"), "--out", str(out), in_process=True)
    assert result.returncode == 0, result.stderr
    assert snapshot(out) == snapshot(good_build)


def test_non_utf8_path_inside_the_xacro_is_refused(mini: tuple[Path, Path], tmp_path: Path) -> None:
    """$(find) puts the folder's name into the XML, which cannot carry it: one line naming it."""
    project, out = mini
    package = tmp_path / NOT_UTF8
    shutil.copytree(MINI, package)
    edit(project / "mini.xacro", 'filename="cube.stl"/>', 'filename="$(find mypkg)/cube.stl"/>')
    args = ["build", "--config", str(project / "mini.yaml"), "--out", str(out), "--package", f"mypkg={package}"]
    fails_cleanly(out, *args, match="/cube.stl' is not UTF-8")


def test_exponent_without_a_dot_is_a_number(mini: tuple[Path, Path]) -> None:
    """YAML 1.1 reads ``1e-3`` as text; the config takes it as the number everyone means (seeded fault: the
    resolver removed from yamlio, and this build fails with "must be a number, got '1e-3'")."""
    project, out = mini
    edit(project / "mini.yaml", "timestep: 0.001", "timestep: 1e-3")
    edit(project / "mini.yaml", "kp: 1.0", "kp: 1E0")
    result = run_cli("build", "--config", str(project / "mini.yaml"), "--out", str(out), "--force", in_process=True)
    assert result.returncode == 0, result.stderr
    assert 'timestep="0.001"' in (out / "mini" / "mini.xml").read_text()


def test_an_arm_side_error_names_the_arm_s_xacro(project: Callable[..., Path]) -> None:
    """An error in ur5.xacro's joints names ur5.xacro and the macro call's line, not ur5_svh.urdf.xacro."""
    root = project()
    ur5 = root / "xacro" / "ur5.xacro"
    edit(ur5, 'effort="${effort}" velocity="${pi}"', 'effort="${-effort}" velocity="${pi}"')
    line = next(n for n, text in enumerate(ur5.read_text().splitlines(), 1) if 'name="shoulder_pan_joint"' in text)
    config_file, out = str(root / "config" / "svhdesc.yaml"), str(root / "out")
    where = f"ur5.xacro:{line}: joint shoulder_pan_joint: effort must be >= 0"
    fails_cleanly(None, "build", "ur5_svh_right", "--config", config_file, "--out", out, match=where)


def test_a_staged_file_is_named_by_where_it_goes() -> None:
    """Errors name OUT/<variant>/..., never the internal staging folder (seeded fault: _published_name returning
    the path as given)."""
    import errno

    from svhdesc.compiler.pipeline.outdir import fs_error

    staged = "/tmp/out/.svhdesc-build-x1y2/svh_right/assets/a_hull_00.obj"
    error = fs_error(Path("/tmp/out"), OSError(errno.ENOSPC, "No space", staged))
    assert str(error) == "/tmp/out/svh_right/assets/a_hull_00.obj: no space left on the device"
