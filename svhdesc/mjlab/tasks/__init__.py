"""The SVH tasks in mjlab's registry, through its ``mjlab.tasks`` entry point (pyproject.toml): ``import mjlab``
imports this package, so ``train Svh-Rotate`` and ``play Svh-Rotate`` of mjlab's own CLI find them. Each task's robot
is its default variant's, or the one ``svhdesc mjlab --variant`` checked and named (svhdesc.mjlab.command)."""

from __future__ import annotations

from mjlab.tasks.manipulation.rl import ManipulationOnPolicyRunner
from mjlab.tasks.registry import list_tasks, register_mjlab_task

from svhdesc.learn.tasks import lift as learn_lift
from svhdesc.learn.tasks import rotate as learn_rotate
from svhdesc.learn.train import no_code_state
from svhdesc.mjlab import lift, rotate
from svhdesc.mjlab.command import registered_variant
from svhdesc.mjlab.runner import rl_cfg


class Runner(ManipulationOnPolicyRunner):
    """mjlab's manipulation runner (each checkpoint with its ONNX policy), without rsl-rl's code-state store: it
    writes git/<repository>.diff of whichever repository holds the installed packages (a venv inside a checkout: that
    checkout's uncommitted work) into every run folder, as ``svhdesc train``'s runner does not either."""

    def __init__(self, *args: object, **kwargs: object) -> None:
        super().__init__(*args, **kwargs)
        self.logger._store_code_state = no_code_state


for module, learned, experiment in ((rotate, learn_rotate, "svh_rotate"), (lift, learn_lift, "ur5_svh_lift")):
    if module.TASK_ID in list_tasks():  # imported once by mjlab's entry point, once more by a user's import
        continue
    variant = registered_variant(module.TASK_ID, module.VARIANT)
    register_mjlab_task(
        task_id=module.TASK_ID,
        env_cfg=module.env_cfg(variant),
        play_env_cfg=module.env_cfg(variant, play=True),
        rl_cfg=rl_cfg(learned.TASK, experiment),
        runner_cls=Runner,
    )
