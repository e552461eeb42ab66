"""``Ur5-Svh-Lift``: ``svhdesc.learn``'s ``ur5_lift`` in mjlab's managers, on mjlab's own lifting command
(``LiftingCommandCfg``: it places the object, draws the target and counts success within 5 cm) and its lift
rewards (``staged_position_reward``, ``bring_object_reward``). From ``ur5_lift``: the table, the place on it, the
lift height, the tolerance, the pre-grasp pose, the grasp point in the tool frame, the box (``ur5_lift`` draws a
box, a cylinder or a sphere per episode: here the box alone), the weights, control rate, episode and PPO settings."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

from svhdesc.learn.scene import add_shape, add_table
from svhdesc.learn.tasks import lift
from svhdesc.mjlab import common, entity
from svhdesc.mjlab import mdp as svh

TASK_ID = "Ur5-Svh-Lift"
VARIANT = "ur5_svh_right"
BOX = lift.SHAPES[0]
GRASP = ("tool0", "grasp", lift.HELD_IN_TOOL)  # a site where a held object's centre sits
RESTING = lift.TABLE_TOP + BOX.size[2] + 0.001  # the box's centre lying on the table
PLACE = {"x": (lift.SPOT[0] - 0.03, lift.SPOT[0] + 0.03), "y": (lift.SPOT[1] - 0.02, lift.SPOT[1] + 0.02)}
STD = 0.1  # m: ur5_lift's reaching and bringing kernels' width


def box_spec() -> Any:
    import mujoco

    spec = mujoco.MjSpec()
    add_shape(spec, BOX)
    return spec


def table(spec: Any) -> None:
    add_table(spec, *lift.TABLE)


def env_cfg(variant: str | Path = VARIANT, play: bool = False) -> Any:
    from mjlab.entity import EntityCfg
    from mjlab.scene import SceneCfg

    task = lift.TASK
    facts = entity.built(variant)
    robot = entity.robot_cfg(variant, channels=task.actions.default, sites=(GRASP,))
    box = EntityCfg(spec_fn=box_spec, init_state=EntityCfg.InitialStateCfg(pos=(*lift.SPOT, RESTING)))
    scene = SceneCfg(num_envs=1, env_spacing=0.0, entities={"robot": robot, "object": box}, spec_fn=table)
    events = {**common.robot_events(facts, 0.0), **common.object_events("object", task)}
    managers = {"observations": _observations(), "actions": _actions(facts), "commands": _commands(), "events": events}
    cfg = common.env_cfg(task, facts, scene, play, rewards=_rewards(), terminations=_terminations(), **managers)
    if play:
        cfg.commands["lift_height"].resampling_time_range = (task.episode_s, task.episode_s)
    return cfg


def _actions(facts: entity.Built) -> dict[str, Any]:
    """The hand's channels scaled by their control ranges (the entity's scale), the arm's joints by ur5_lift's."""
    from mjlab.envs.mdp.actions import JointPositionActionCfg

    hand = facts.hand
    arm_scale = lift.TASK.actions.arm_scale
    scale = {
        entity.exact_name(joint): value if hand is not None and hand.owns(joint) else arm_scale
        for joint, value in entity.action_scale(facts).items()
    }
    return {"joint_pos": JointPositionActionCfg(entity_name="robot", actuator_names=(".*",), scale=scale)}


def _commands() -> dict[str, Any]:
    from mjlab.tasks.manipulation.mdp import LiftingCommandCfg

    above = RESTING + lift.LIFT
    return {
        "lift_height": LiftingCommandCfg(
            entity_name="object",
            resampling_time_range=(1e9, 1e9),  # drawn at each reset only, as ur5_lift's target
            success_threshold=lift.TOLERANCE,
            difficulty="dynamic",
            target_position_range=LiftingCommandCfg.TargetPositionRangeCfg(**PLACE, z=(above, above)),
            object_pose_range=LiftingCommandCfg.ObjectPoseRangeCfg(
                **PLACE, z=(RESTING, RESTING), yaw=(-math.pi, math.pi)
            ),
        )
    }


def _observations() -> dict[str, Any]:
    from mjlab.envs import mdp
    from mjlab.managers import ObservationGroupCfg, ObservationTermCfg
    from mjlab.managers.scene_entity_config import SceneEntityCfg
    from mjlab.tasks.manipulation import mdp as manipulation

    widths = {term.name: term.noise for term in lift.TASK.actor}  # ur5_lift's sensed terms' noise

    def noise(name: str) -> Any:
        return common.noise(widths[name])

    grasp = SceneEntityCfg("robot", site_names=(GRASP[1],))
    actor = {
        "joint_pos": ObservationTermCfg(func=mdp.joint_pos_rel, noise=noise("joint_pos")),
        "last_action": ObservationTermCfg(func=mdp.last_action),
        "grasp_to_object": ObservationTermCfg(
            func=manipulation.ee_to_object_distance,
            params={"object_name": "object", "asset_cfg": grasp},
            noise=noise("object_pos"),
        ),
        "object_to_target": ObservationTermCfg(
            func=manipulation.object_to_goal_distance,
            params={"object_name": "object", "command_name": "lift_height"},
            noise=noise("object_pos"),
        ),
        "object_rot": ObservationTermCfg(
            func=svh.object_rot6d, params={"object_name": "object"}, noise=noise("object_rot")
        ),
    }
    critic = {
        **{name: ObservationTermCfg(func=term.func, params=term.params) for name, term in actor.items()},
        "joint_vel": ObservationTermCfg(func=mdp.joint_vel_rel),
        "object_linvel": ObservationTermCfg(func=svh.object_lin_vel, params={"object_name": "object"}),
        "object_angvel": ObservationTermCfg(func=svh.object_ang_vel, params={"object_name": "object"}),
    }
    return {
        "actor": ObservationGroupCfg(actor, enable_corruption=True),
        "critic": ObservationGroupCfg(critic, enable_corruption=False),
    }


def _rewards() -> dict[str, Any]:
    from mjlab.envs import mdp
    from mjlab.managers.reward_manager import RewardTermCfg
    from mjlab.managers.scene_entity_config import SceneEntityCfg
    from mjlab.tasks.manipulation import mdp as manipulation

    weights = {reward.name: reward.weight for reward in lift.TASK.rewards}
    target = {"command_name": "lift_height", "object_name": "object"}
    grasp = SceneEntityCfg("robot", site_names=(GRASP[1],))
    staged = {**target, "reaching_std": STD, "bringing_std": STD, "asset_cfg": grasp}
    fell = {"object_name": "object", "height": lift.TABLE_TOP - 0.05}
    return {
        "lift": RewardTermCfg(func=manipulation.staged_position_reward, weight=weights["lift"], params=staged),
        "lift_precise": RewardTermCfg(
            func=manipulation.bring_object_reward,
            weight=weights["lift_precise"],
            params={**target, "std": lift.TOLERANCE},
        ),
        "action_rate": RewardTermCfg(func=mdp.action_rate_l2, weight=weights["action_rate"]),
        "fell": RewardTermCfg(func=svh.below_penalty, weight=weights["fell"], params=fell),
    }


def _terminations() -> dict[str, Any]:
    from mjlab.envs import mdp
    from mjlab.managers.termination_manager import TerminationTermCfg

    fell = {"object_name": "object", "height": lift.TABLE_TOP - 0.05}
    return {
        "time_out": TerminationTermCfg(func=mdp.time_out, time_out=True),
        "fell": TerminationTermCfg(func=svh.below, params=fell),
    }
