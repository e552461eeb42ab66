"""``svhdesc play``: one episode of a trained policy in one world, drawn offscreen as a strip of frames.

The episode runs in this process (the exported ONNX actor, MuJoCo C or Warp); the picture is drawn by a child
(``python -m svhdesc.learn.play``), as every svhdesc picture is (svhdesc.offscreen: MuJoCo binds its OpenGL backend
at import). The child composes the same task scene, takes the world's randomised parameters and draws each saved
state.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path
from typing import Any

import numpy as np

from svhdesc.learn.policy import OnnxPolicy
from svhdesc.learn.spec import Task
from svhdesc.offscreen import draw_pixels, run_child, stage, write_png

FRAME = (320, 240)  # pixels of one frame in the strip


def record(env: Any, policy: OnnxPolicy, frames: int) -> tuple[list[dict[str, Any]], dict[str, Any]]:
    """One episode of world 0 (the env's first): ``frames`` states spread over it, and the episode's figures."""
    import torch

    length = env.max_episode_length
    keep = set(np.linspace(0, length - 1, frames).round().astype(int).tolist())
    states: list[dict[str, Any]] = [_state(env)]
    obs = env.observe()[0]
    env.stats.clear()
    for step in range(1, length + 1):
        observations, _, done, _ = env.step(torch.as_tensor(policy(obs.cpu().numpy()), device=env.device))
        obs = observations["actor"]
        if bool(done[0]):
            break
        if step in keep:
            states.append(_state(env))
    figures = env.stats.read()
    figures["steps"] = step
    return states, figures


def _state(env: Any) -> dict[str, Any]:
    markers = env.task.markers(env)[0].tolist() if env.task.markers is not None else []
    return {"qpos": env.qpos[0].tolist(), "markers": markers}


def draw(task: Task, source: str, params: dict[str, list[Any]], states: list[dict[str, Any]], out: Path) -> str:
    """The strip (one frame per state, left to right) as a PNG, drawn in a child process; returns the backend."""
    request = {"task": task.name, "source": source, "params": params, "states": states, "out": str(out)}
    out.parent.mkdir(parents=True, exist_ok=True)
    return run_child([sys.executable, "-m", "svhdesc.learn.play"], stdin=json.dumps(request))


def world_params(env: Any, world: int = 0) -> dict[str, list[Any]]:
    return {name: value[world].cpu().tolist() for name, value in env.physics.model.items()}


def _draw_child() -> int:
    import mujoco

    from svhdesc.learn.scene import compose_spec
    from svhdesc.learn.tasks import task

    request = json.loads(sys.stdin.read())
    spec_task = task(request["task"])
    spec = compose_spec(spec_task.scene, request["source"])
    for geom in [g for g in spec.geoms if g.name == "table_top"]:
        spec.delete(geom)  # the table's collision plane: the picture shows its box
    markers = len(request["states"][0]["markers"])
    for k in range(markers):  # mocap bodies, the last ones: their geoms come after the scene's
        spec.worldbody.add_body(name=f"marker_{k}", mocap=True).add_geom(
            name=f"marker_{k}",
            type=mujoco.mjtGeom.mjGEOM_SPHERE,
            size=(0.008, 0.0, 0.0),
            rgba=(0.1, 0.8, 0.2, 0.8),
            contype=0,
            conaffinity=0,
        )
    stage(spec)
    model = spec.compile()
    for name, value in request["params"].items():
        array = np.asarray(value, dtype=float)
        target = getattr(model, name)[: len(array)]  # the markers' geoms are not the world's
        target[...] = array.reshape(target.shape)
    data = mujoco.MjData(model)
    camera = mujoco.MjvCamera()
    lookat, distance, azimuth, elevation = spec_task.camera
    camera.lookat[:], camera.distance, camera.azimuth, camera.elevation = lookat, distance, azimuth, elevation
    pictures = []
    for state in request["states"]:
        data.qpos[:] = state["qpos"]
        data.mocap_pos[: len(state["markers"])] = state["markers"]
        mujoco.mj_forward(model, data)
        pictures.append(draw_pixels(model, data, camera, FRAME))
    write_png(Path(request["out"]), np.concatenate(pictures, axis=1))
    return 0


if __name__ == "__main__":
    sys.exit(_draw_child())
