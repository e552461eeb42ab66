"""mjlab's own train entry point (``mjlab.scripts.train:main``, the ``train`` command pip installs with mjlab) on
svhdesc's two tasks, found through the ``mjlab.tasks`` entry point, on the CPU (no GPU selected: MuJoCo Warp's CPU
device): 2 PPO iterations each of 2 worlds x 4 steps (the fewest that run the entry point end to end; the cost is
MuJoCo Warp compiling its CPU kernels, not the steps), each writing its checkpoints and its ONNX policy, and no
diff of the checkout (rsl-rl's code-state store, switched off as svhdesc train's). And the
registry: both tasks with their play variants, whose episodes do not end. In .venv-mjlab (see test_entity.py)."""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

pytest.importorskip("mjlab")

import torch  # noqa: E402
from mjlab.tasks.registry import list_tasks, load_env_cfg, load_rl_cfg  # noqa: E402

TASKS = {"Svh-Rotate": "svh_rotate", "Ur5-Svh-Lift": "ur5_svh_lift"}


def test_the_tasks_and_their_play_variants_are_registered() -> None:
    assert set(TASKS) <= set(list_tasks())
    for task, experiment in TASKS.items():
        train, play = load_env_cfg(task), load_env_cfg(task, play=True)
        assert play.episode_length_s > 1e6 > train.episode_length_s
        assert train.observations["actor"].enable_corruption and not play.observations["actor"].enable_corruption
        assert load_rl_cfg(task).experiment_name == experiment
        assert load_rl_cfg(task).logger == "tensorboard"


@pytest.mark.parametrize("task", TASKS)
def test_mjlab_train_writes_a_checkpoint(task: str, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    from mjlab.scripts import train

    options = ["--env.scene.num-envs", "2", "--agent.max-iterations", "2", "--agent.num-steps-per-env", "4"]
    options += ["--gpu-ids", "None", "--log-root", str(tmp_path)]
    monkeypatch.setattr(sys, "argv", ["train", task, *options])
    monkeypatch.setenv("CUDA_VISIBLE_DEVICES", "")  # train sets it; the test leaves the process as it found it
    train.main()
    runs = list((tmp_path / TASKS[task]).iterdir())
    assert len(runs) == 1, runs
    checkpoint = runs[0] / "model_1.pt"  # the last of 2 iterations
    assert checkpoint.is_file(), sorted(p.name for p in runs[0].iterdir())
    state = torch.load(checkpoint, map_location="cpu", weights_only=False)
    assert state["iter"] == 1
    assert list(runs[0].glob("*.onnx")), "no ONNX policy"
    assert not (runs[0] / "git").exists(), "rsl-rl stored the checkout's diff"  # seeded: Runner's override removed
