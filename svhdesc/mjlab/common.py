"""What both mjlab tasks build alike from an ``svhdesc.learn`` task: the environment's frame (physics, control rate,
episode, viewer), the play variant, the robot's resets and the object's randomisation as mjlab events."""

from __future__ import annotations

from typing import Any

from svhdesc.learn.spec import Task
from svhdesc.mjlab import entity
from svhdesc.mjlab import mdp as svh


def env_cfg(task: Task, facts: entity.Built, scene: Any, play: bool, **managers: Any) -> Any:
    """mjlab's ``ManagerBasedRlEnvCfg``: the task's physics step and Warp capacities on the variant's solver
    options, its control rate (decimation) and episode, its camera; ``managers`` as mjlab names them."""
    from mjlab.envs import ManagerBasedRlEnvCfg
    from mjlab.sim import SimulationCfg

    cfg = ManagerBasedRlEnvCfg(
        scene=scene,
        sim=SimulationCfg(
            nconmax=task.scene.nconmax,
            njmax=task.scene.njmax,
            mujoco=entity.mujoco_cfg(facts, task.scene.physics_dt),
        ),
        decimation=round(1.0 / (task.control_hz * task.scene.physics_dt)),
        episode_length_s=task.episode_s,
        **managers,
    )
    cfg.viewer.lookat = task.camera[0]
    cfg.viewer.distance = task.camera[1]
    if play:  # mjlab's play variant: an episode without end, the observations without noise
        cfg.episode_length_s = int(1e9)
        cfg.observations["actor"].enable_corruption = False
    return cfg


def noise(width: float) -> Any:
    from mjlab.utils.noise import UniformNoiseCfg

    return UniformNoiseCfg(n_min=-width, n_max=width)


def robot_events(facts: entity.Built, jitter: float) -> dict[str, Any]:
    """The base placed (mjlab moves a fixed base only by an event) and the joints reset with the couplings kept."""
    from mjlab.envs import mdp
    from mjlab.managers.event_manager import EventTermCfg

    return {
        "reset_base": EventTermCfg(func=mdp.reset_root_state_uniform, mode="reset", params={"pose_range": {}}),
        "reset_robot": EventTermCfg(
            func=svh.reset_coupled_joints, mode="reset", params={"jitter": jitter, "couplings": facts.couplings}
        ),
    }


def object_events(name: str, task: Task) -> dict[str, Any]:
    """The object's friction and mass drawn once per world at start-up from the task's randomisation ranges
    (``svhdesc.learn`` draws them at every reset)."""
    from mjlab.envs.mdp import dr
    from mjlab.managers.event_manager import EventTermCfg
    from mjlab.managers.scene_entity_config import SceneEntityCfg

    randomisation = task.randomisation
    return {
        f"{name}_friction": EventTermCfg(
            func=dr.geom_friction,
            mode="startup",
            params={"asset_cfg": SceneEntityCfg(name, geom_names=(".*",)), "ranges": randomisation.object_friction},
        ),
        f"{name}_mass": EventTermCfg(
            func=dr.body_mass,
            mode="startup",
            params={
                "asset_cfg": SceneEntityCfg(name, body_names=(".*",)),
                "ranges": randomisation.object_mass,
                "operation": "abs",
            },
        ),
    }
