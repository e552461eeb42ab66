"""``Svh-Rotate``: ``svhdesc.learn``'s ``svh_rotate`` in mjlab's managers. The hand (palm up, its base, the cupped
pose at action 0), the cube, the drop distance, the clipped yaw-rate reward and its weights, the control rate and
episode length, the network and PPO settings are ``svh_rotate``'s own, imported from it. mjlab's managers take the
rest: observations with uniform noise (``svh_rotate``: the same widths), resets by events, the episode's time-out."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

from svhdesc.learn.scene import add_shape
from svhdesc.learn.tasks import rotate
from svhdesc.mjlab import common, entity
from svhdesc.mjlab import mdp as svh

TASK_ID = "Svh-Rotate"
VARIANT = "svh_right"
REST = tuple(p + z for p, z in zip(rotate.PALM, (0.0, 0.0, rotate.CUBE.size[2]), strict=True))  # the cube at rest
JITTER = 0.05  # rad about the cupped pose at reset, as svh_rotate's


def cube_spec() -> Any:
    import mujoco

    spec = mujoco.MjSpec()
    add_shape(spec, rotate.CUBE)
    return spec


def env_cfg(variant: str | Path = VARIANT, play: bool = False) -> Any:
    from mjlab.entity import EntityCfg
    from mjlab.scene import SceneCfg

    task = rotate.TASK
    facts = entity.built(variant)
    robot = entity.robot_cfg(variant, channels=task.actions.default, base=rotate.BASE)
    cube = EntityCfg(spec_fn=cube_spec, init_state=EntityCfg.InitialStateCfg(pos=(REST[0], REST[1], REST[2] + 0.005)))
    scene = SceneCfg(num_envs=1, env_spacing=0.0, entities={"robot": robot, "cube": cube})
    managers = {"observations": _observations(), "actions": _actions(facts), "events": _events(facts)}
    return common.env_cfg(task, facts, scene, play, rewards=_rewards(), terminations=_terminations(), **managers)


def _actions(facts: entity.Built) -> dict[str, Any]:
    from mjlab.envs.mdp.actions import JointPositionActionCfg

    scale = {entity.exact_name(joint): value for joint, value in entity.action_scale(facts).items()}
    return {"joint_pos": JointPositionActionCfg(entity_name="robot", actuator_names=(".*",), scale=scale)}


def _observations() -> dict[str, Any]:
    from mjlab.envs import mdp
    from mjlab.managers import ObservationGroupCfg, ObservationTermCfg

    widths = {term.name: term.noise for term in rotate.TASK.actor}  # svh_rotate's sensed terms' noise

    def noise(name: str) -> Any:
        return common.noise(widths[name])

    cube = {"object_name": "cube"}
    actor = {
        "joint_pos": ObservationTermCfg(func=mdp.joint_pos_rel, noise=noise("joint_pos")),
        "last_action": ObservationTermCfg(func=mdp.last_action),
        "cube_pos": ObservationTermCfg(func=svh.object_offset, params={**cube, "rest": REST}, noise=noise("cube_pos")),
        "cube_rot": ObservationTermCfg(func=svh.object_rot6d, params=cube, noise=noise("cube_rot")),
    }
    critic = {
        "joint_pos": ObservationTermCfg(func=mdp.joint_pos_rel),
        "joint_vel": ObservationTermCfg(func=mdp.joint_vel_rel),
        "last_action": ObservationTermCfg(func=mdp.last_action),
        "cube_pos": ObservationTermCfg(func=svh.object_offset, params={**cube, "rest": REST}),
        "cube_rot": ObservationTermCfg(func=svh.object_rot6d, params=cube),
        "cube_linvel": ObservationTermCfg(func=svh.object_lin_vel, params=cube),
        "cube_angvel": ObservationTermCfg(func=svh.object_ang_vel, params=cube),
    }
    return {
        "actor": ObservationGroupCfg(actor, enable_corruption=True),
        "critic": ObservationGroupCfg(critic, enable_corruption=False),
    }


def _events(facts: entity.Built) -> dict[str, Any]:
    from mjlab.envs import mdp
    from mjlab.managers.event_manager import EventTermCfg
    from mjlab.managers.scene_entity_config import SceneEntityCfg

    place = {"x": (-0.005, 0.005), "y": (-0.005, 0.005), "yaw": (-math.pi, math.pi)}
    reset_cube = EventTermCfg(
        func=mdp.reset_root_state_uniform,
        mode="reset",
        params={"pose_range": place, "velocity_range": {}, "asset_cfg": SceneEntityCfg("cube")},
    )
    return {**common.robot_events(facts, JITTER), "reset_cube": reset_cube, **common.object_events("cube", rotate.TASK)}


def _rewards() -> dict[str, Any]:
    from mjlab.envs import mdp
    from mjlab.managers.reward_manager import RewardTermCfg

    weights = {reward.name: reward.weight for reward in rotate.TASK.rewards}
    cube = {"object_name": "cube"}
    dropped = {**cube, "rest": REST, "distance": rotate.DROP}
    return {
        "yaw_rate": RewardTermCfg(
            func=svh.yaw_rate, weight=weights["yaw_rate"], params={**cube, "limit": rotate.MAX_RATE}
        ),
        "off_palm": RewardTermCfg(func=svh.off_rest, weight=weights["off_palm"], params={**cube, "rest": REST}),
        "dropped": RewardTermCfg(func=svh.dropped_penalty, weight=weights["dropped"], params=dropped),
        "action_rate": RewardTermCfg(func=mdp.action_rate_l2, weight=weights["action_rate"]),
    }


def _terminations() -> dict[str, Any]:
    from mjlab.envs import mdp
    from mjlab.managers.termination_manager import TerminationTermCfg

    dropped = {"object_name": "cube", "rest": REST, "distance": rotate.DROP}
    return {
        "time_out": TerminationTermCfg(func=mdp.time_out, time_out=True),
        "dropped": TerminationTermCfg(func=svh.dropped, params=dropped),
    }
