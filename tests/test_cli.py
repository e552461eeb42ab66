"""CLI behaviour: bad input exits 2 with one line and changes nothing; --check; list/info; atomic writes."""

from __future__ import annotations

import shutil
from collections.abc import Callable
from pathlib import Path

import pytest

from tests.support import fails_cleanly, run_cli

CONFIG = "config/svhdesc.yaml"  # in a copy of the project


@pytest.fixture
def out(tmp_path: Path, session_build: Path) -> Path:
    """An output directory holding a previous good build of svh_right."""
    target = tmp_path / "out"
    shutil.copytree(session_build / "svh_right", target / "svh_right")
    return target


def build_fails_cleanly(out: Path, *args: str, match: str) -> str:
    """``svhdesc build svh_right --out OUT ARGS`` fails cleanly and leaves ``out`` as it was."""
    return fails_cleanly(out, "build", "svh_right", "--out", str(out), *args, match=match)


def test_malformed_xacro_names_file_and_line(out: Path, project: Callable[..., Path]) -> None:
    root = project()
    source = root / "xacro" / "svh.xacro"
    lines = source.read_text().splitlines()
    number = next(i for i, line in enumerate(lines) if '<xacro:macro name="svh_hand"' in line)
    lines[number] = lines[number].replace("<xacro:macro", "<xacro:macro <")
    source.write_text("\n".join(lines))
    message = build_fails_cleanly(out, "--config", str(root / CONFIG), match=f"svh.xacro:{number + 1}:")
    assert "malformed XML" in message


def test_missing_mesh_is_named(out: Path, project: Callable[..., Path]) -> None:
    root = project()
    (root / "meshes" / "svh" / "t.dae").unlink()
    build_fails_cleanly(out, "--config", str(root / CONFIG), match="t.dae")


def test_unknown_package_is_named(out: Path, project: Callable[..., Path]) -> None:
    config = project() / CONFIG
    config.write_text(config.read_text().replace("svhdesc: ..", "other: .."))
    assert "other: .." in config.read_text()
    build_fails_cleanly(out, "--config", str(config), match="unknown package 'svhdesc'")


def test_bad_coupling_spec_is_named(out: Path, project: Callable[..., Path]) -> None:
    root = project()
    spec = root / "config" / "coupling.yaml"
    spec.write_text(spec.read_text().replace("joint: j15,", "joint: j99,"))
    build_fails_cleanly(out, "--config", str(root / CONFIG), match="coupling.yaml:")


def test_vendor_limit_contradiction_is_refused_in_strict_mode(out: Path, project: Callable[..., Path]) -> None:
    root = project()
    source = root / "xacro" / "svh.xacro"
    text = source.read_text()
    assert "1.39457" in text  # our fixed j15 limit
    source.write_text(text.replace("1.39457", "1.334"))
    build_fails_cleanly(out, "--config", str(root / CONFIG), match="j15")


def test_unknown_variant(out: Path) -> None:
    build_fails_cleanly(out, "no_such_hand", match="unknown variant 'no_such_hand'")


def test_unreadable_config(out: Path, tmp_path: Path) -> None:
    build_fails_cleanly(out, "--config", str(tmp_path / "absent.yaml"), match="absent.yaml")
    broken = tmp_path / "broken.yaml"
    broken.write_text("variants: [unclosed\n")
    build_fails_cleanly(out, "--config", str(broken), match="broken.yaml:")


@pytest.mark.slow
def test_check_passes_on_a_fresh_build_and_lists_a_changed_file(tmp_path: Path, session_build: Path) -> None:
    out = tmp_path / "gen"
    shutil.copytree(session_build, out)
    assert run_cli("build", "--check", "--trust-cache", "--out", str(out)).returncode == 0
    urdf = out / "svh_left" / "svh_left.urdf"
    urdf.write_bytes(urdf.read_bytes() + b"\n")
    (out / "svh_right" / "assets" / "stale.stl").write_bytes(b"x")
    result = run_cli("build", "--check", "--trust-cache", "--out", str(out))
    assert result.returncode == 1
    assert "svh_left/svh_left.urdf" in result.stderr and "stale.stl" in result.stderr
    assert urdf.read_bytes().endswith(b"\n\n")  # --check changes nothing


def test_list_and_info() -> None:
    listed = run_cli("list", in_process=True)
    assert listed.returncode == 0
    assert [line.split()[0] for line in listed.stdout.splitlines()] == [
        "svh_right",
        "svh_left",
        "ur5_svh_right",
    ]
    info = run_cli("info", "ur5_svh_right", in_process=True)
    assert info.returncode == 0, info.stderr
    assert "26 joints, 15 DoF (11 coupled), 15 actuators" in info.stdout
    row = next(line for line in info.stdout.splitlines() if line.strip().startswith("j15 "))
    assert "1.045" in row


@pytest.mark.slow
def test_vendor_description_builds_with_this_projects_spec(vendor_build: tuple[Path, object]) -> None:
    out, result = vendor_build
    assert "right_hand_j15" in result.stderr and "limit widened" in result.stderr  # type: ignore[attr-defined]
    assert (out / "svh_vendor_right" / "svh_vendor_right.xml").is_file()


def test_a_long_command_does_not_keep_its_warnings(capfd: pytest.CaptureFixture[str]) -> None:
    """The ROS node runs inside the CLI's wrapper while rospy warns on every /clock message: memory must
    stay flat over many warnings, each still echoed once. Seeded fault: the former
    ``catch_warnings(record=True)`` keeps every warning (8 MB over the second 10,000 here)."""
    import tracemalloc
    import warnings

    from svhdesc.cli import _friendly

    def warn(count: int) -> None:
        for index in range(count):
            warnings.warn(f"clock message {index}", UserWarning, stacklevel=1)
            warnings.warn(f"deprecated {index}", DeprecationWarning, stacklevel=1)

    def command() -> int:
        warn(10_000)
        before = tracemalloc.get_traced_memory()[0]
        warn(10_000)
        return tracemalloc.get_traced_memory()[0] - before

    tracemalloc.start()
    try:
        growth = _friendly(command)()
    finally:
        tracemalloc.stop()
    err = capfd.readouterr().err
    assert growth < 200_000, f"{growth} bytes kept over 10,000 warnings"
    assert err.count("warning: clock message") == 20_000 and "deprecated" not in err
