"""Many worlds of one hand at once on MuJoCo Warp: ``svhdesc.batch.make(variant, nworld=N, device=...)``.

    env = svhdesc.batch.make("svh_right", nworld=1024, device="cuda")   # or device="cpu"
    env.reset("home")                        # every world to keyframe home; env.reset("test", worlds=[0, 3])
    env.step(ctrl)                           # ctrl: [nworld, nu] servo targets, one physics step (nstep=...)
    obs = env.observations()                 # qpos, qvel [nworld, nq|nv], fingertips [nworld, 5, 3], touch

The model is the variant's ``scene_batch.xml`` (see ``svhdesc.compiler.export.batch``), whose ``<size>`` states the
per-world contact and constraint capacities Warp preallocates. Warp drops what does not fit; every step
checks its overflow flags and raises BatchOverflow instead of letting a world run on without them.
Needs ``pip install 'svhdesc[batch]'`` (mujoco-warp, warp-lang).
"""

from __future__ import annotations

from svhdesc.batch.env import BatchEnv, BatchOverflow, make

__all__ = ["BatchEnv", "BatchOverflow", "make"]
