"""The SVH tasks in mjlab's registry, through its ``mjlab.tasks`` entry point (pyproject.toml): ``import mjlab``
imports this package, so ``train Svh-Rotate`` and ``play Svh-Rotate`` of mjlab's own CLI find them. Each task's robot
is its default variant's, or the one ``svhdesc mjlab --variant`` checked and named (svhdesc.mjlab.command)."""

from __future__ import annotations

from mjlab.tasks.manipulation.rl import ManipulationOnPolicyRunner
from mjlab.tasks.registry import list_tasks, register_mjlab_task

from svhdesc.learn.tasks import lift as learn_lift
from svhdesc.learn.tasks import rotate as learn_rotate
from svhdesc.mjlab import lift, rotate
from svhdesc.mjlab.command import registered_variant
from svhdesc.mjlab.runner import rl_cfg

for module, learned, experiment in ((rotate, learn_rotate, "svh_rotate"), (lift, learn_lift, "ur5_svh_lift")):
    if module.TASK_ID in list_tasks():  # imported once by mjlab's entry point, once more by a user's import
        continue
    variant = registered_variant(module.TASK_ID, module.VARIANT)
    register_mjlab_task(
        task_id=module.TASK_ID,
        env_cfg=module.env_cfg(variant),
        play_env_cfg=module.env_cfg(variant, play=True),
        rl_cfg=rl_cfg(learned.TASK, experiment),
        runner_cls=ManipulationOnPolicyRunner,
    )
