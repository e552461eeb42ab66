"""mjlab's runner configuration for an svhdesc task: ``svhdesc train``'s PPO settings (``ppo_config``) in mjlab's
dataclasses, logged to TensorBoard (mjlab's default is Weights & Biases, which needs an account)."""

from __future__ import annotations

from typing import Any

from svhdesc.learn.spec import Task
from svhdesc.learn.train import ppo_config


def rl_cfg(task: Task, experiment: str) -> Any:
    from mjlab.rl import RslRlModelCfg, RslRlOnPolicyRunnerCfg, RslRlPpoAlgorithmCfg

    ppo = ppo_config(task.training)
    algorithm = {key: value for key, value in ppo["algorithm"].items() if key != "class_name"}
    return RslRlOnPolicyRunnerCfg(
        actor=RslRlModelCfg(**{**_model(ppo["actor"]), "distribution_cfg": ppo["actor"]["distribution_cfg"]}),
        critic=RslRlModelCfg(**_model(ppo["critic"])),
        algorithm=RslRlPpoAlgorithmCfg(**algorithm),
        experiment_name=experiment,
        num_steps_per_env=ppo["num_steps_per_env"],
        save_interval=ppo["save_interval"],
        seed=ppo["seed"],
        logger="tensorboard",
        upload_model=False,
    )


def _model(model: dict[str, Any]) -> dict[str, Any]:
    return {
        "hidden_dims": tuple(model["hidden_dims"]),
        "activation": model["activation"],
        "obs_normalization": model["obs_normalization"],
    }
