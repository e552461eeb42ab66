"""A repository's [tool.svhdesc] table: the models `svhdesc validate` alone validates, xacro argument choices (one model
per combination), packages, checks ignored with a reason; every fault in the table one error at pyproject.toml:line.
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from tests.support import run_cli
from tests.validate.test_static_files import MACROS, XACRO

PYPROJECT = """[project]
name = "my-robot"

[tool.svhdesc]
models = ["urdf/*.urdf.xacro"]
ignore = {{ meshes = "the meshes live in a submodule" }}

[tool.svhdesc.model."urdf/arm.urdf.xacro"]
args = {{ side = ["left", "right"] }}
{extra}
"""


@pytest.fixture
def repo(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    (tmp_path / "urdf").mkdir()
    (tmp_path / "urdf" / "arm.urdf.xacro").write_text(XACRO.replace("${LOWER}", "-1.0"))
    (tmp_path / "urdf" / "macros.xacro").write_text(MACROS)
    (tmp_path / "pyproject.toml").write_text(PYPROJECT.format(extra=""))
    monkeypatch.chdir(tmp_path / "urdf")  # found at or above the working folder, as ruff's and pytest's are
    return tmp_path


def _validate(*args: str) -> tuple[int, str, str]:
    result = run_cli("validate", *args, in_process=True)
    return result.returncode, result.stdout, result.stderr


def test_validate_alone_takes_the_models_and_their_argument_choices(repo: Path) -> None:
    code, out, err = _validate("--format", "json")
    assert code == 0, out + err
    reports = json.loads(out)
    assert [r["path"] for r in reports] == [
        f"{repo}/urdf/arm.urdf.xacro[side=left]",
        f"{repo}/urdf/arm.urdf.xacro[side=right]",
    ]
    meshes = [c for c in reports[0]["checks"] if c["name"] == "meshes"]
    assert meshes[0]["status"] == "skipped" and "the meshes live in a submodule" in meshes[0]["reason"]


def test_a_fault_in_one_argument_choice_is_found_in_that_one(repo: Path) -> None:
    # side=right builds joints named right_*: a limit inverted only for that side.
    faulty = XACRO.replace("${LOWER}", "${-1.0 if side == 'left' else 2.0}")
    (repo / "urdf" / "arm.urdf.xacro").write_text(faulty)
    code, out, _ = _validate()
    assert code == 1
    assert "joint_limits: joint 'right_shoulder'" in out and "left_shoulder" not in out
    # The command line's --arg wins over the table's choices.
    assert _validate("arm.urdf.xacro", "--arg", "side:=left")[0] == 0


@pytest.mark.parametrize(
    "extra, words",
    [
        ('ignore = { inertials = "" }', """'ignore' in [tool.svhdesc.model."urdf/arm.urdf.xacro"] must be"""),
        ('select = ["gravity"]', "unknown check 'gravity'"),
        ("colour = 1", "unknown key 'colour'"),
        ('packages = { arm = "nowhere" }', "folder nowhere does not exist"),
        ("args = { side = }", "not valid TOML"),
        ('pose = { left_shoulder = "up" }', "'pose' in [tool.svhdesc.model."),
    ],
)
def test_a_malformed_table_is_one_error_at_its_line(repo: Path, extra: str, words: str) -> None:
    text = PYPROJECT.format(extra=extra)
    (repo / "pyproject.toml").write_text(text)
    line = text.splitlines().index(extra) + 1
    before = sorted(repo.rglob("*"))
    code, out, err = _validate()
    assert code == 2 and out == "" and err.count("\n") == 1, err
    assert err.startswith(f"error: {repo / 'pyproject.toml'}:{line}: ") and words in err, err
    assert sorted(repo.rglob("*")) == before


def test_a_models_pattern_that_matches_nothing_is_an_error(repo: Path) -> None:
    (repo / "pyproject.toml").write_text(PYPROJECT.format(extra="").replace("urdf/*.urdf.xacro", "mjcf/*.xml"))
    code, _, err = _validate()
    assert code == 2 and "'mjcf/*.xml' matches no file" in err and "pyproject.toml:5:" in err


def test_an_svhdesc_yaml_beside_the_model_adds_its_validate_section(repo: Path) -> None:
    faulty = XACRO.replace("${LOWER}", "${-1.0 if side == 'left' else 2.0}")
    (repo / "urdf" / "arm.urdf.xacro").write_text(faulty)
    beside = repo / "urdf" / "svhdesc.yaml"
    beside.write_text("variants: {}\n")  # a build config of the same name: no validate section, not read
    assert _validate()[0] == 1
    beside.write_text("validate:\n  ignore:\n    joint_limits: the right arm's limits are being reworked\n")
    code, out, err = _validate("--format", "json")
    assert code == 0, out + err
    limits = [c for r in json.loads(out) for c in r["checks"] if c["name"] == "joint_limits"]
    assert {c["status"] for c in limits} == {"skipped"} and "being reworked" in limits[0]["reason"]
    beside.write_text("validate:\n  ignore:\n    joint_limits: ok\n  colour: 1\n")
    code, _, err = _validate()
    assert code == 2 and f"{beside}:4: unknown key 'colour'" in err, err


def test_a_pose_naming_no_joint_of_the_model_is_one_error(repo: Path) -> None:
    (repo / "pyproject.toml").write_text(PYPROJECT.format(extra="pose = { elbow = 0.5 }"))
    code, out, err = _validate()
    assert code == 2 and out == "" and "pose names joint 'elbow', which the model does not have" in err, err
    (repo / "pyproject.toml").write_text(
        PYPROJECT.format(extra="").replace('side = ["left", "right"]', 'side = "left"')
    )
    (repo / "urdf" / "svhdesc.yaml").write_text("validate:\n  pose: {left_shoulder: 0.5}\n")
    assert _validate()[0] == 0  # a joint it has: the pose is taken (the arm has no collisions to judge)
