"""An ONNX policy's svhdesc metadata is read defensively: metadata that is not JSON, not a JSON object, without the
actor's widths, or whose widths are not the model's or the task's is one ``error:`` line naming the file, exit 2,
in ``play`` and in ``deploy`` (nothing written: play's strip is not drawn).

Seeded faults, each failing the test named: ``_metadata`` calling ``json.loads`` unguarded (a JSONDecodeError
traceback: test_metadata_that_is_not_a_json_object); ``_metadata`` not asking for an object (``.get`` on a list:
an AttributeError traceback, the same test); ``_check_ports`` not comparing the widths with the model's ports
(test_widths_that_are_not_the_models); ``check_fits`` not called in ``run_play`` or ``task_simulation`` (play fails
at its first step instead, deploy in its policy node: test_widths_that_are_not_the_tasks).
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest

onnx = pytest.importorskip("onnx")
pytest.importorskip("onnxruntime")
pytest.importorskip("torch")

from onnx import TensorProto, helper  # noqa: E402

from tests.support import fails_cleanly, run_cli  # noqa: E402

REACH = {"format": 1, "task": "svh_reach", "actor_obs": 24, "critic_obs": 33, "actions": 9}


def actor(folder: Path, metadata: str, inputs: int = 24, outputs: int = 9, name: str = "policy.onnx") -> Path:
    """An ONNX actor (``actions = obs @ 0``, the batch free) carrying ``metadata`` as svhdesc's."""
    weights = helper.make_tensor("w", TensorProto.FLOAT, [inputs, outputs], [0.0] * (inputs * outputs))
    graph = helper.make_graph(
        [helper.make_node("MatMul", ["obs", "w"], ["actions"])],
        "actor",
        [helper.make_tensor_value_info("obs", TensorProto.FLOAT, ["batch", inputs])],
        [helper.make_tensor_value_info("actions", TensorProto.FLOAT, ["batch", outputs])],
        initializer=[weights],
    )
    model = helper.make_model(graph, opset_imports=[helper.make_opsetid("", 18)])
    model.ir_version = 9  # what this onnxruntime reads
    entry = model.metadata_props.add()
    entry.key, entry.value = "svhdesc", metadata
    path = folder / name
    onnx.save(model, path)
    return path


def _refused_by_play_and_deploy(folder: Path, policy: Path, match: str) -> None:
    picture = folder / "strip.png"
    lines = [
        fails_cleanly(folder, "play", "svh_reach", "--checkpoint", str(policy), "--out", str(picture), match=match),
        fails_cleanly(folder, "deploy", "svh_reach", "--policy", str(policy), match=match),
    ]
    assert all(line.startswith(f"error: {policy}: ") for line in lines), lines
    assert not picture.exists()


@pytest.mark.parametrize(
    ("metadata", "match"),
    [
        ("{'task': 'svh_reach'}", "svhdesc's metadata in it is not JSON (Expecting property name"),
        ("", "svhdesc's metadata in it is not JSON"),
        ("[" * 100_000 + "]" * 100_000, "svhdesc's metadata in it is nested too deep to read"),
        ('["svh_reach", 24]', "svhdesc's metadata in it is not a JSON object but list"),
        ("null", "svhdesc's metadata in it is not a JSON object but NoneType"),
        ('"svh_reach"', "svhdesc's metadata in it is not a JSON object but str"),
    ],
    ids=["python-dict", "empty", "deep", "list", "null", "string"],
)
def test_metadata_that_is_not_a_json_object(tmp_path: Path, metadata: str, match: str) -> None:
    _refused_by_play_and_deploy(tmp_path, actor(tmp_path, metadata), match)


def test_widths_that_are_not_the_models(tmp_path: Path) -> None:
    for key, value in (("actor_obs", "24"), ("actions", 0), ("actions", True), ("actor_obs", None)):
        policy = actor(tmp_path, json.dumps({**REACH, key: value}))
        _refused_by_play_and_deploy(tmp_path, policy, f"has no positive integer {key} (it has {value!r})")
    policy = actor(tmp_path, json.dumps({**REACH, "actor_obs": 30}))
    _refused_by_play_and_deploy(
        tmp_path, policy, "the model's 'obs' has shape ['batch', 24], its metadata says actor_obs 30"
    )
    policy = actor(tmp_path, json.dumps(REACH), outputs=4)
    _refused_by_play_and_deploy(tmp_path, policy, "the model's 'actions' has shape ['batch', 4], its metadata says")


def test_widths_that_are_not_the_tasks(tmp_path: Path) -> None:
    """A policy whose model and metadata agree, but of observations 20 wide (a task changed since): refused by name
    once the task's environment is made, before an episode runs or the ROS 2 node starts."""
    policy = actor(tmp_path, json.dumps({**REACH, "actor_obs": 20}), inputs=20)
    _refused_by_play_and_deploy(tmp_path, policy, "actor_obs 20 in it, the task's environment has 24")


def test_a_sound_policy_plays(tmp_path: Path) -> None:
    """The checks refuse only what is wrong: the same crafted actor with the task's widths plays an episode."""
    result = run_cli("play", "svh_reach", "--checkpoint", str(actor(tmp_path, json.dumps(REACH))), "--episodes", "1",
                     in_process=True)  # fmt: skip
    assert result.returncode == 0 and "error" not in result.stderr, result.stderr
    assert "svh_reach on the main model (mujoco): success" in result.stdout, result.stdout
