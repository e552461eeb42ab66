"""Learning on the built models: tasks (``svhdesc.learn.tasks``), their environment over MuJoCo Warp or MuJoCo C
(``TaskEnv``), PPO training with rsl-rl, the exported policy run in MuJoCo C and through the ROS 2 node.

    from svhdesc.learn import TaskEnv, task
    env = TaskEnv(task("svh_rotate"), num_envs=4096, device="cuda")   # rsl-rl's VecEnv

Needs ``pip install 'svhdesc[rl]'`` (torch, rsl-rl-lib, onnxruntime, and the batch extra).
"""

from __future__ import annotations

from svhdesc.learn.tasks import TASKS, task

__all__ = ["TASKS", "task"]
