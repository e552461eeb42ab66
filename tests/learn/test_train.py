"""Training end to end on the CPU: two PPO iterations on Warp's CPU device end with finite losses in TensorBoard, a
checkpoint that reloads to the exported actor's actions, and ``--resume`` continuing its count; every bad input to
``svhdesc train`` and ``svhdesc play`` is one ``error:`` line, exit 2, and nothing written.

Seeded faults, each failing the test named: ``export_onnx`` exporting a fresh runner's (untrained) actor
(test_two_iterations_on_warp); ``train`` not loading the ``--resume`` checkpoint (the iteration count restarts at 0:
test_resume_continues); ``load_checkpoint`` not comparing the task (test_bad_inputs_are_one_line, play and resume
of another task's checkpoint); ``_out`` accepting a non-empty folder (the same test).
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

torch = pytest.importorskip("torch")
pytest.importorskip("rsl_rl")
pytest.importorskip("onnxruntime")

from svhdesc.learn import task  # noqa: E402
from svhdesc.learn.env import TaskEnv  # noqa: E402
from svhdesc.learn.policy import OnnxPolicy  # noqa: E402
from svhdesc.learn.train import make_runner, ppo_config, train  # noqa: E402
from tests.support import fails_cleanly  # noqa: E402


def _scalars(folder: Path) -> dict[str, list[float]]:
    from tensorboard.backend.event_processing.event_accumulator import EventAccumulator

    events = EventAccumulator(str(folder))
    events.Reload()
    return {tag: [e.value for e in events.Scalars(tag)] for tag in events.Tags()["scalars"]}


@pytest.fixture(scope="module")
def cpu_run(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Two iterations in MuJoCo C: a checkpoint and an actor of svh_reach, in seconds."""
    reach = task("svh_reach")
    out = tmp_path_factory.mktemp("cpu_run")
    return train(reach, TaskEnv(reach, 4, backend="mujoco", seed=2), out, None, 2, say=lambda line: None)


@pytest.fixture(scope="module")
def warp_run(tmp_path_factory: pytest.TempPathFactory) -> Path:
    pytest.importorskip("mujoco_warp")
    reach = task("svh_reach")
    env = TaskEnv(reach, 4, device="cpu", backend="warp", seed=2)
    out = tmp_path_factory.mktemp("warp_run")
    lines: list[str] = []
    last = train(reach, env, out, minutes=None, iterations=2, say=lines.append)
    assert len(lines) == 2 and lines[1].startswith("it 1  env-steps 128  ")
    return last


@pytest.mark.slow
def test_two_iterations_on_warp(warp_run: Path) -> None:
    scalars = _scalars(warp_run.parent)
    losses = {tag: values for tag, values in scalars.items() if tag.startswith("Loss/")}
    assert {"Loss/value", "Loss/surrogate"} <= set(losses), sorted(scalars)
    assert all(len(v) == 2 and all(math.isfinite(x) for x in v) for v in losses.values()), losses
    assert warp_run.name == "model_1.pt"
    reach = task("svh_reach")
    env = TaskEnv(reach, 3, device="cpu", backend="mujoco", seed=9)
    runner = make_runner(env, ppo_config(reach.training), None)
    runner.load(str(warp_run), map_location="cpu")
    obs = env.get_observations()
    torch_actions = runner.get_inference_policy()(obs).detach().numpy()
    onnx_actions = OnnxPolicy(warp_run.parent / "policy.onnx", reach)(obs["actor"].numpy())
    assert np.allclose(torch_actions, onnx_actions, atol=1e-5)
    assert not np.allclose(onnx_actions, 0.0, atol=1e-3)  # the trained actor, not a blank one


@pytest.mark.slow
def test_resume_continues(cpu_run: Path, tmp_path: Path) -> None:
    reach = task("svh_reach")
    env = TaskEnv(reach, 4, device="cpu", backend="mujoco", seed=2)
    last = train(reach, env, tmp_path, minutes=None, iterations=1, resume=cpu_run, say=lambda line: None)
    assert last.name == "model_2.pt"
    saved = torch.load(str(last), weights_only=True)
    assert saved["iter"] == 2 and saved["infos"]["task"] == "svh_reach"


def reach_files(folder: Path) -> tuple[str, str]:
    """A checkpoint and an ONNX actor of svh_reach as svhdesc writes their task into them (the networks are not
    needed to refuse them for another task): made in milliseconds, for the fast set."""
    import onnx
    from onnx import TensorProto, helper

    from svhdesc.learn.checkpoint import FORMAT

    infos = {"format": FORMAT, "task": "svh_reach"}
    checkpoint = folder / "model_3.pt"
    torch.save({"iter": 3, "infos": infos}, checkpoint)
    graph = helper.make_graph(
        [helper.make_node("Identity", ["obs"], ["actions"])],
        "actor",
        [helper.make_tensor_value_info("obs", TensorProto.FLOAT, [None, 4])],
        [helper.make_tensor_value_info("actions", TensorProto.FLOAT, [None, 4])],
    )
    model = helper.make_model(graph)
    entry = model.metadata_props.add()
    entry.key, entry.value = "svhdesc", json.dumps(infos)
    actor = folder / "policy.onnx"
    onnx.save(model, actor)
    return str(checkpoint), str(actor)


def test_bad_inputs_are_one_line(tmp_path: Path) -> None:
    out = tmp_path / "run"
    reach_ckpt, reach_onnx = reach_files(tmp_path)
    common = ("--backend", "mujoco", "--iterations", "1", "--out", str(out))
    fails_cleanly(None, "train", "svh_juggle", *common, match="unknown task 'svh_juggle'")
    fails_cleanly(None, "train", "svh_reach", "--envs", "0", *common, match="--envs must be at least 1")
    fails_cleanly(
        None, "train", "svh_reach", "--envs", "2", "--backend", "mujoco", "--out", str(out), match="--minutes"
    )
    fails_cleanly(None, "train", "svh_rotate", "--resume", reach_ckpt, *common, match="of task 'svh_reach'")
    fails_cleanly(None, "play", "svh_rotate", "--checkpoint", reach_ckpt, match="of task 'svh_reach'")
    fails_cleanly(None, "play", "svh_rotate", "--checkpoint", reach_onnx, match="of task 'svh_reach'")
    fails_cleanly(None, "play", "svh_reach", "--checkpoint", str(tmp_path / "none.pt"), match="no such checkpoint")
    if not torch.cuda.is_available():
        fails_cleanly(None, "train", "svh_reach", "--device", "cuda", *common[2:], match="no CUDA GPU")
    assert not out.exists()
    out.mkdir()
    (out / "model_7.pt").write_bytes(b"")
    fails_cleanly(out, "train", "svh_reach", *common, match="not an empty folder")
