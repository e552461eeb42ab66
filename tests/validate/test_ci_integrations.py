"""The CI integrations of `svhdesc validate PATH`, run for real on a temporary git repository holding a robot.

- The pre-commit hooks (.pre-commit-hooks.yaml) through the pre-commit package: `pre-commit try-repo` on the
  checkout as it stands, and a repository's own .pre-commit-config.yaml installed as its git hook, refusing a commit.
  Seeded fault: the elbow's limits inverted; the output must name arm.urdf at the <limit> element's line.
- The GitHub Action (action.yml): its run: steps' scripts run here as the runner runs them (bash -eo pipefail, the
  step's env, $GITHUB_OUTPUT), with ${{ inputs.* }} and ${{ github.action_path }} set to the test's values; its
  uses: step (actions/setup-python) is not run: a virtual environment made from this interpreter stands for the
  Python it sets up. The install step really pip-installs this checkout into that environment.
- A hook passes every changed *.xml by name: a package.xml or a launch file is skipped with a note, not refused.
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
import sysconfig
from pathlib import Path
from typing import Any

import pytest
import yaml
from lxml import etree

from tests.support import REPO, fails_cleanly, run_cli

HOOKS = REPO / ".pre-commit-hooks.yaml"
ACTION = REPO / "action.yml"

# A clean two-link arm: inertials, limits with effort and velocity, primitive geometry (no mesh to resolve).
ARM = """<?xml version="1.0"?>
<robot name="arm">
  <link name="base">
    <inertial>
      <mass value="2"/>
      <inertia ixx="0.01" ixy="0" ixz="0" iyy="0.01" iyz="0" izz="0.01"/>
    </inertial>
    <collision>
      <geometry><cylinder radius="0.05" length="0.1"/></geometry>
    </collision>
  </link>
  <link name="upper">
    <inertial>
      <origin xyz="0 0 0.15"/>
      <mass value="1"/>
      <inertia ixx="0.008" ixy="0" ixz="0" iyy="0.008" iyz="0" izz="0.0005"/>
    </inertial>
    <visual>
      <origin xyz="0 0 0.15"/>
      <geometry><box size="0.04 0.04 0.3"/></geometry>
    </visual>
    <collision>
      <origin xyz="0 0 0.15"/>
      <geometry><box size="0.04 0.04 0.3"/></geometry>
    </collision>
  </link>
  <link name="fore">
    <inertial>
      <origin xyz="0 0 0.1"/>
      <mass value="0.5"/>
      <inertia ixx="0.002" ixy="0" ixz="0" iyy="0.002" iyz="0" izz="0.0002"/>
    </inertial>
    <visual>
      <origin xyz="0 0 0.1"/>
      <geometry><box size="0.03 0.03 0.2"/></geometry>
    </visual>
    <collision>
      <origin xyz="0 0 0.1"/>
      <geometry><box size="0.03 0.03 0.2"/></geometry>
    </collision>
  </link>
  <joint name="shoulder" type="revolute">
    <parent link="base"/>
    <child link="upper"/>
    <origin xyz="0 0 0.06"/>
    <axis xyz="0 1 0"/>
    <limit lower="-1.5" upper="1.5" effort="30" velocity="2"/>
  </joint>
  <joint name="elbow" type="revolute">
    <parent link="upper"/>
    <child link="fore"/>
    <origin xyz="0 0 0.31"/>
    <axis xyz="0 1 0"/>
    <limit lower="-2" upper="2" effort="10" velocity="2"/>
  </joint>
</robot>
"""
CLEAN_LIMIT = '<limit lower="-2" upper="2" effort="10" velocity="2"/>'
INVERTED = ARM.replace(CLEAN_LIMIT, '<limit lower="2" upper="-2" effort="10" velocity="2"/>')
LIMIT_LINE = ARM.splitlines().index(f"    {CLEAN_LIMIT}") + 1
FINDING = f"urdf/arm.urdf:{LIMIT_LINE}: joint_limits: joint 'elbow': lower 2 > upper -2"
PACKAGE_XML = '<?xml version="1.0"?>\n<package format="3">\n  <name>arm_description</name>\n</package>\n'
LAUNCH_XML = '<launch>\n  <node pkg="robot_state_publisher" exec="robot_state_publisher"/>\n</launch>\n'


def _env(**extra: str) -> dict[str, str]:
    """The environment of every git, pre-commit and step process: a commit identity, and no PYTHONPATH, which would
    let a hook's or a step's Python import svhdesc from this checkout instead of what its install put there."""
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "VIRTUAL_ENV")}
    identity = {"NAME": "svhdesc tests", "EMAIL": "tests@svhdesc.invalid"}
    env.update({f"GIT_{who}_{key}": value for who in ("AUTHOR", "COMMITTER") for key, value in identity.items()})
    env.update(PRE_COMMIT_COLOR="never", **extra)
    return env


def _git(cwd: Path, *args: str, env: dict[str, str] | None = None) -> str:
    result = subprocess.run(
        ["git", "-c", "commit.gpgsign=false", *args], cwd=cwd, env=env or _env(), capture_output=True, text=True
    )
    assert result.returncode == 0, (args, result.stdout, result.stderr)
    return result.stdout


def _robot_repo(root: Path, urdf: str = ARM) -> Path:
    """A robot description's repository: urdf/arm.urdf beside a package.xml and a launch file, nothing committed."""
    (root / "urdf").mkdir(parents=True)
    (root / "launch").mkdir()
    (root / "urdf" / "arm.urdf").write_text(urdf)
    (root / "package.xml").write_text(PACKAGE_XML)
    (root / "launch" / "display.launch.xml").write_text(LAUNCH_XML)
    _git(root, "init", "-q")
    return root


def _snapshot(dest: Path) -> tuple[Path, str]:
    """The checkout as `pre-commit try-repo` takes it (HEAD, then the staged files and the tracked files' changes),
    committed in a clone: try-repo's own shadow repository, made here so that one rev serves several pre-commit runs.
    The clone's objects are written there, never into the checkout's."""
    _git(REPO, "clone", "-q", "--no-checkout", str(REPO), str(dest))
    _git(dest, "read-tree", "HEAD")
    shadow = _env(GIT_INDEX_FILE=str(dest / ".git" / "index"), GIT_OBJECT_DIRECTORY=str(dest / ".git" / "objects"))
    staged = _git(REPO, "diff", "--cached", "--name-only", "--diff-filter=d", "-z").split("\0")
    if any(staged):
        _git(REPO, "add", "--", *filter(None, staged), env=shadow)
    _git(REPO, "add", "-u", env=shadow)
    _git(dest, "commit", "-q", "--allow-empty", "-m", "the checkout as it stands")
    rev = _git(dest, "rev-parse", "HEAD").strip()
    listed = subprocess.run(["git", "cat-file", "-e", f"{rev}:.pre-commit-hooks.yaml"], cwd=dest)
    assert listed.returncode == 0, "pre-commit reads committed files: stage or commit .pre-commit-hooks.yaml first"
    return dest, rev


def _pre_commit(cwd: Path, *args: str, home: Path) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "pre_commit", *args],
        cwd=cwd,
        env=_env(PRE_COMMIT_HOME=str(home)),
        capture_output=True,
        text=True,
        timeout=900,
    )


def test_the_hooks_are_a_valid_manifest_on_robot_files() -> None:
    """pre-commit's own schema; the files each hook gets (robot files, not macro libraries or other files); the
    tiers; the validate extra in the hook's environment (`svhdesc validate` refuses to start without it)."""
    from pre_commit.clientlib import load_manifest

    hooks = {hook["id"]: hook for hook in load_manifest(str(HOOKS))}
    assert set(hooks) == {"svhdesc-validate-static", "svhdesc-validate"}
    assert hooks["svhdesc-validate-static"]["entry"] == "svhdesc validate --tier static"
    assert hooks["svhdesc-validate"]["entry"] == "svhdesc validate --tier full"
    changed = ["urdf/arm.urdf", "urdf/arm.urdf.xacro", "mjcf/scene.xml", "package.xml", "urdf/macros.xacro", "a.py"]
    for hook in hooks.values():
        assert hook["language"] == "python" and hook["pass_filenames"]
        assert hook["additional_dependencies"] == ["svhdesc[validate]"]
        files = re.compile(hook["files"])
        assert [f for f in changed if files.search(f)] == changed[:4]
    assert hooks["svhdesc-validate-static"]["require_serial"]  # one process: one interpreter start


def test_a_hook_skips_xml_that_is_not_a_robot_file(tmp_path: Path) -> None:
    """A package.xml and a launch file given by name are skipped with one note each, the robot beside them checked;
    a broken MJCF is still refused. Seeded fault: robot_files without the skip exits 2 on package.xml."""
    repo = _robot_repo(tmp_path)
    given = [str(repo / "package.xml"), str(repo / "launch" / "display.launch.xml"), str(repo / "urdf" / "arm.urdf")]
    result = run_cli("validate", "--tier", "static", *given, cwd=repo)  # a process: its stderr alone
    assert result.returncode == 0, result.stdout + result.stderr
    assert result.stdout == "1 model(s): all checks passed\n"
    assert result.stderr.splitlines() == [
        f"{given[0]}: skipped, not a robot file (root <package>)",
        f"{given[1]}: skipped, not a robot file (root <launch>)",
    ]
    only_other = run_cli("validate", "--tier", "static", given[0], in_process=True)
    assert only_other.returncode == 0 and only_other.stdout == "0 model(s): all checks passed\n"
    (tmp_path / "scene.xml").write_text("<mujoco>\n  <worldbody>\n</mujoco>\n")
    fails_cleanly(None, "validate", "--tier", "static", str(tmp_path / "scene.xml"), match="scene.xml:3")


@pytest.mark.slow
def test_pre_commit_try_repo_passes_a_clean_model(tmp_path: Path) -> None:
    """`pre-commit try-repo` as a user tries the hook before adding it: a fresh environment with svhdesc and the
    validate extra pip-installed from the checkout (try-repo's store is its own temporary folder, so this installs
    every time), the changed files passed, package.xml skipped."""
    hooks, rev = _snapshot(tmp_path / "hooks")
    repo = _robot_repo(tmp_path / "robot")
    _git(repo, "add", "-A")
    files = ["urdf/arm.urdf", "package.xml"]
    args = ("try-repo", str(hooks), "svhdesc-validate-static", "--ref", rev, "--verbose", "--files", *files)
    result = _pre_commit(repo, *args, home=tmp_path / "home")
    output = result.stdout + result.stderr
    assert result.returncode == 0, output
    assert re.search(r"svhdesc validate \(static\)\.+Passed", output), output
    assert "package.xml: skipped, not a robot file (root <package>)" in output
    assert "1 model(s): all checks passed" in output


@pytest.mark.slow
def test_an_installed_hook_refuses_a_commit_with_a_seeded_fault(tmp_path: Path) -> None:
    """A repository's .pre-commit-config.yaml naming both hooks, installed as its git hook: the clean arm commits
    (static and full tier pass), the arm with the elbow's limits inverted does not, and the output names arm.urdf
    at the <limit> line; the same change made right commits."""
    hooks, rev = _snapshot(tmp_path / "hooks")
    repo = _robot_repo(tmp_path / "robot")
    config = {"repos": [{"repo": str(hooks), "rev": rev, "hooks": [{"id": "svhdesc-validate-static"}]}]}
    config["repos"][0]["hooks"].append({"id": "svhdesc-validate"})
    (repo / ".pre-commit-config.yaml").write_text(yaml.safe_dump(config))
    home = tmp_path / "home"
    installed = _pre_commit(repo, "install", "--install-hooks", home=home)
    assert installed.returncode == 0, installed.stdout + installed.stderr
    env = _env(PRE_COMMIT_HOME=str(home))

    def commit(message: str) -> subprocess.CompletedProcess[str]:
        _git(repo, "add", "-A", env=env)
        args = ["git", "-c", "commit.gpgsign=false", "commit", "-m", message]
        return subprocess.run(args, cwd=repo, env=env, capture_output=True, text=True, timeout=600)

    clean = commit("a clean arm")
    output = clean.stdout + clean.stderr  # git runs the hook with its stdout on git's stderr
    assert clean.returncode == 0, output
    assert re.search(r"svhdesc validate \(static\)\.+Passed", output), output
    assert re.search(r"svhdesc validate\.+Passed", output), output
    (repo / "urdf" / "arm.urdf").write_text(INVERTED)
    refused = commit("the elbow's limits inverted")
    output = refused.stdout + refused.stderr
    assert refused.returncode != 0, output
    assert re.search(r"svhdesc validate \(static\)\.+Failed", output), output
    assert FINDING in output, output
    assert _git(repo, "rev-list", "--count", "HEAD").strip() == "1"
    (repo / "urdf" / "arm.urdf").write_text(ARM.replace('upper="2"', 'upper="2.5"'))
    put_right = commit("the elbow's range widened")
    assert put_right.returncode == 0, put_right.stdout + put_right.stderr


EXPRESSION = re.compile(r"\$\{\{\s*(.*?)\s*\}\}")


def _action() -> dict[str, Any]:
    return yaml.safe_load(ACTION.read_text())


def _expressions(value: object) -> list[str]:
    if isinstance(value, dict):
        return [e for v in value.values() for e in _expressions(v)]
    if isinstance(value, list):
        return [e for v in value for e in _expressions(v)]
    return EXPRESSION.findall(value) if isinstance(value, str) else []


def test_the_action_is_composite_and_uses_every_input() -> None:
    """Every input declared with a description and a default is used by a step, and every expression of the steps
    is one the step runner below can set (an input, the action's path, the validate step's output)."""
    action = _action()
    assert action["runs"]["using"] == "composite"
    inputs = action["inputs"]
    assert {"paths", "tier", "args", "python-version", "junit"} <= set(inputs)
    assert all(spec.get("description") and "default" in spec for spec in inputs.values())
    steps = action["runs"]["steps"]
    used = _expressions(steps) + _expressions(action.get("outputs", {}))
    assert {e.removeprefix("inputs.") for e in used if e.startswith("inputs.")} == set(inputs)
    assert set(used) <= {f"inputs.{name}" for name in inputs} | {"github.action_path", "steps.validate.outputs.junit"}
    assert [s["uses"] for s in steps if "uses" in s] == ["actions/setup-python@v5"]
    assert all(s["shell"] == "bash" for s in steps if "run" in s)
    assert [s.get("id") for s in steps][-1] == "validate"
    # Inputs reach a script through env:, never pasted into its text (a workflow's expression is not shell code).
    assert not [e for s in steps if "run" in s for e in EXPRESSION.findall(s["run"])]


def _run_step(step: dict[str, Any], values: dict[str, str], workspace: Path, env: dict[str, str]) -> Any:
    """One run: step as the runner runs it: bash -eo pipefail on the script, the step's env:, $GITHUB_OUTPUT."""

    def expand(text: str) -> str:
        return EXPRESSION.sub(lambda m: values[m.group(1)], text)

    script = workspace.parent / "step.sh"
    script.write_text(expand(step["run"]))
    step_env = {**env, **{name: expand(str(value)) for name, value in step.get("env", {}).items()}}
    return subprocess.run(
        ["bash", "--noprofile", "--norc", "-eo", "pipefail", str(script)],
        cwd=workspace,
        env=step_env,
        capture_output=True,
        text=True,
        timeout=600,
    )


@pytest.mark.slow
def test_the_action_steps_annotate_a_seeded_fault_and_pass_a_clean_model(tmp_path: Path) -> None:
    """The install step pip-installs this checkout with the validate extra into a virtual environment of this
    interpreter (standing for setup-python's; this environment's packages seen through a .pth, so only svhdesc is
    built and installed); the validate step then runs that svhdesc: the clean arm passes with the defaults (the
    repository walked, the full tier), the arm with inverted limits fails with a workflow annotation at its line."""
    action = _action()
    steps = [s for s in action["runs"]["steps"] if "run" in s]  # the uses: step (actions/setup-python) is not run
    python = tmp_path / "python"
    subprocess.run([sys.executable, "-m", "venv", str(python)], check=True, env=_env())
    site = subprocess.run(
        [python / "bin" / "python", "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"],
        capture_output=True,
        text=True,
        check=True,
    ).stdout.strip()
    Path(site, "ci_test_packages.pth").write_text(sysconfig.get_paths()["purelib"] + "\n")
    workspace = _robot_repo(tmp_path / "workspace")
    output = tmp_path / "github_output"
    env = _env(
        PATH=f"{python / 'bin'}{os.pathsep}{os.environ['PATH']}",
        GITHUB_ACTIONS="true",
        GITHUB_WORKSPACE=str(workspace),
        GITHUB_ACTION_PATH=str(REPO),
        GITHUB_OUTPUT=str(output),
    )

    def values(**inputs: str) -> dict[str, str]:
        given = {name: str(spec["default"]) for name, spec in action["inputs"].items()} | inputs
        return {f"inputs.{name}": value for name, value in given.items()} | {"github.action_path": str(REPO)}

    install = _run_step(steps[0], values(), workspace, env)
    assert install.returncode == 0, install.stdout + install.stderr
    where = subprocess.run(
        [python / "bin" / "python", "-c", "import svhdesc; print(svhdesc.__file__)"],
        capture_output=True,
        text=True,
        env=env,
        cwd=workspace,
    )
    assert where.stdout.startswith(site), where.stdout + where.stderr  # the installed copy, not this checkout

    (validate,) = steps[1:]
    clean = _run_step(validate, values(), workspace, env)
    assert clean.returncode == 0, clean.stdout + clean.stderr
    assert "::error" not in clean.stdout
    assert output.read_text() == "junit=svhdesc-validate.xml\n"
    cases = {c.get("name"): c for c in etree.parse(str(workspace / "svhdesc-validate.xml")).iter("testcase")}
    assert {"joint_limits", "mujoco_compile", "gravity_hold"} <= set(cases)  # the full tier, by default
    assert all(c.find("failure") is None for c in cases.values())

    (workspace / "urdf" / "arm.urdf").write_text(INVERTED)
    inputs = {"paths": "urdf", "tier": "static", "args": "--ignore mimic", "junit": "reports/validate.xml"}
    (workspace / "reports").mkdir()
    faulty = _run_step(validate, values(**inputs), workspace, env)
    assert faulty.returncode == 1, faulty.stdout + faulty.stderr
    annotation = f"::error file=urdf/arm.urdf,line={LIMIT_LINE},title=svhdesc joint_limits::joint 'elbow': lower 2"
    assert faulty.stdout.startswith(annotation), faulty.stdout
    cases = {c.get("name"): c for c in etree.parse(str(workspace / "reports" / "validate.xml")).iter("testcase")}
    assert "mimic" not in cases and "gravity_hold" not in cases  # args and tier reached the command
    assert cases["joint_limits"].find("failure") is not None
