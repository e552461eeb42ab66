"""IR -> a MoveIt configuration: SRDF, kinematics, joint limits, controllers (MoveIt's simple
controller manager and ros_control), and a launch file loading them. Renders only: the collision
matrix comes from ``svhdesc.compiler.probes.collision_matrix``."""

from __future__ import annotations

from collections.abc import Mapping

from lxml import etree

from svhdesc.compiler.export.xmlfmt import num, serialise, sub
from svhdesc.compiler.export.yamlfmt import GENERATED, dump_yaml
from svhdesc.ir import Robot
from svhdesc.model import (
    ACTION,
    ACTION_MONITOR_RATE,
    ARM_CONTROLLER,
    CONSTRAINTS,
    DECLARES_CONSTRAINTS,
    STATE_PUBLISH_RATE,
    VELOCITY_SERVO_CONTROLLER,
    VELOCITY_SERVO_TYPE,
    hand_controller,
)

ARM_GROUP = "manipulator"
HAND_GROUP = "hand"
BOTH_GROUP = "arm_hand"  # the thesis planned arm and hand as one group (with BioIK)
# ROS-Industrial's frame names (REP-I0005): the chain runs between them where the robot has them on its arm.
ARM_BASE, ARM_TIP = "base_link", "tool0"
STATE_RATE = 50
REQUEST_ADAPTERS = tuple(
    f"default_planner_request_adapters/{name}"
    for name in (
        "AddTimeOptimalParameterization",
        "FixWorkspaceBounds",
        "FixStartStateBounds",
        "FixStartStateCollision",
        "FixStartStatePathConstraints",
    )
)


def hand_prefix(robot: Robot) -> str:
    """The hand's prefix (``right_hand``), which names its controller; ``hand`` for a hand without one."""
    return robot.hand.prefix or "hand"


def hand_joints(robot: Robot) -> list[str]:
    """Every movable hand joint: the channels' joints and the joints coupled to them."""
    driven = {c.joint for c in robot.channels} | {c.joint for c in robot.couplings}
    prefixed = {f"{hand_prefix(robot)}_{c.joint}" for c in robot.couplings}
    return [j.name for j in robot.joints if j.movable and (j.name in driven or j.name in prefixed)]


def arm_joints(robot: Robot) -> list[str]:
    """The arm's joints on position servos (what its trajectory controllers and planning group drive)."""
    channels = {c.joint for c in robot.channels}
    return [a.joint for a in robot.actuators if a.joint not in channels and not a.velocity]


def velocity_joints(robot: Robot) -> list[str]:
    """The joints on velocity servos (joints.NAME.servo: velocity): a velocity group controller's, planned by none."""
    return [a.joint for a in robot.actuators if a.velocity]


def arm_chain(robot: Robot) -> tuple[str, str]:
    """The arm group's chain: ``base_link`` to ``tool0`` where the arm lies between them, else the first arm
    joint's parent link to the last arm joint's child link."""
    joints = {j.name: j for j in robot.joints}
    parent_of = {j.child: j.parent for j in robot.joints}
    arm = arm_joints(robot)
    base, tip = joints[arm[0]].parent, joints[arm[-1]].child

    def above(link: str) -> set[str]:
        found = {link}
        while link in parent_of:
            link = parent_of[link]
            found.add(link)
        return found

    return (ARM_BASE if ARM_BASE in above(base) else base, ARM_TIP if tip in above(ARM_TIP) else tip)


def passive_joints(robot: Robot) -> list[str]:
    return [j.name for j in robot.joints if j.mimic]


def planning_groups(robot: Robot) -> list[str]:
    arm, hand = bool(arm_joints(robot)), bool(robot.channels)
    return [ARM_GROUP] * arm + [HAND_GROUP] * hand + [BOTH_GROUP] * (arm and hand)


def export_srdf(robot: Robot, collisions: Mapping[tuple[str, str], str]) -> bytes:
    root = etree.Element("robot", name=robot.name)
    root.append(etree.Comment(f" {GENERATED} "))
    groups = planning_groups(robot)
    base, tip = arm_chain(robot) if ARM_GROUP in groups else (ARM_BASE, ARM_TIP)
    if ARM_GROUP in groups:
        group = sub(root, "group", name=ARM_GROUP)
        sub(group, "chain", base_link=base, tip_link=tip)
    if HAND_GROUP in groups:
        group = sub(root, "group", name=HAND_GROUP)
        for joint in hand_joints(robot):
            sub(group, "joint", name=joint)
    if BOTH_GROUP in groups:
        group = sub(root, "group", name=BOTH_GROUP)
        sub(group, "group", name=ARM_GROUP)
        sub(group, "group", name=HAND_GROUP)
    state_group = groups[-1]  # the widest: arm and hand, else whichever the robot has
    active = [a.joint for a in robot.actuators if not a.velocity]  # a group state names its groups' joints
    for keyframe in robot.keyframes:
        values = dict(keyframe.qpos)
        state = sub(root, "group_state", name=keyframe.name, group=state_group)
        for joint in active:
            sub(state, "joint", name=joint, value=num(values[joint]))
    if BOTH_GROUP in groups:
        sub(root, "end_effector", name=HAND_GROUP, parent_link=tip, group=HAND_GROUP, parent_group=ARM_GROUP)
    sub(root, "virtual_joint", name="virtual_joint", type="fixed", parent_frame="world", child_link=robot.root)
    for joint in passive_joints(robot):
        sub(root, "passive_joint", name=joint)
    for (link1, link2), reason in collisions.items():
        sub(root, "disable_collisions", link1=link1, link2=link2, reason=reason)
    return serialise(root)


def export_kinematics(robot: Robot) -> bytes:
    if not arm_joints(robot):
        return dump_yaml({})
    solver = {
        "kinematics_solver": "kdl_kinematics_plugin/KDLKinematicsPlugin",
        "kinematics_solver_search_resolution": 0.005,
        "kinematics_solver_timeout": 0.005,
    }
    return dump_yaml({ARM_GROUP: solver})


def export_joint_limits(robot: Robot) -> bytes:
    limits = {}
    for actuator in robot.actuators:
        joint = robot.joint(actuator.joint)
        limits[joint.name] = {
            "has_velocity_limits": joint.velocity > 0,
            "max_velocity": float(joint.velocity),
            "has_acceleration_limits": False,
            "max_acceleration": 0.0,
        }
    return dump_yaml(
        {"default_velocity_scaling_factor": 0.1, "default_acceleration_scaling_factor": 0.1, "joint_limits": limits}
    )


def _controllers(robot: Robot) -> list[tuple[str, list[str], str]]:
    groups = []
    if robot.channels:
        groups.append((hand_controller(hand_prefix(robot)), [c.joint for c in robot.channels], "hand"))
    if arm_joints(robot):
        groups.append((ARM_CONTROLLER, arm_joints(robot), "arm"))
    return groups


def export_moveit_controllers(robot: Robot) -> bytes:
    """MoveIt's simple controller manager -> the drivers' (and the simulation's) action servers."""
    controllers = [
        {"name": name, "action_ns": ACTION, "type": "FollowJointTrajectory", "default": True, "joints": joints}
        for name, joints, _ in _controllers(robot)
    ]
    return dump_yaml(
        {
            "moveit_controller_manager": "moveit_simple_controller_manager/MoveItSimpleControllerManager",
            "controller_list": controllers,
        }
    )


def export_ros_controllers(robot: Robot, d_gains: Mapping[str, float]) -> bytes:
    """ros_control controllers for the gazebo_ros_control path, matching the URDF transmissions:
    position_controllers over a PositionJointInterface, effort_controllers (with the servo's gains)
    over an EffortJointInterface."""
    interface = {t.joint: t.interface for t in robot.transmissions}
    kp = {a.joint: a.kp for a in robot.actuators}
    document: dict = {
        "joint_state_controller": {"type": "joint_state_controller/JointStateController", "publish_rate": STATE_RATE}
    }
    for name, joints, kind in _controllers(robot):
        kinds = {interface[j] for j in joints}
        effort = kinds == {"hardware_interface/EffortJointInterface"}
        constraints = CONSTRAINTS[kind]
        controller: dict = {
            "type": f"{'effort' if effort else 'position'}_controllers/JointTrajectoryController",
            "joints": joints,
        }
        if DECLARES_CONSTRAINTS[kind]:  # the hand's real config declares none: JTC defaults
            controller["constraints"] = {
                "goal_time": constraints["goal_time"],
                "stopped_velocity_tolerance": constraints["stopped_velocity_tolerance"],
                **{j: {"goal": constraints["goal"], "trajectory": constraints["trajectory"]} for j in joints},
            }
        controller["state_publish_rate"] = STATE_PUBLISH_RATE[kind]
        controller["action_monitor_rate"] = ACTION_MONITOR_RATE[kind]
        controller["allow_partial_joints_goal"] = kind == "hand"
        if effort:
            controller["gains"] = {j: {"p": float(kp[j]), "d": float(d_gains[j]), "i": 0.0} for j in joints}
        document[name] = controller
    if velocity_joints(robot):  # over their VelocityJointInterface
        document[VELOCITY_SERVO_CONTROLLER] = {"type": VELOCITY_SERVO_TYPE, "joints": velocity_joints(robot)}
    return dump_yaml(document)


def export_moveit_launch(robot: Robot) -> bytes:
    """Loads the MoveIt parameters where move_group looks for them (run beside sim.launch)."""
    root = etree.Element("launch")
    root.append(etree.Comment(f" {GENERATED} "))
    root.append(etree.Comment(" then: rosrun moveit_ros_move_group move_group (or your own move_group launch) "))
    package = f"$(find {robot.name})"
    sub(root, "param", name="robot_description_semantic", textfile=f"{package}/config/{robot.name}.srdf")
    planning = sub(root, "group", ns="robot_description_planning")
    sub(planning, "rosparam", command="load", file=f"{package}/config/joint_limits.yaml")
    kinematics = sub(root, "group", ns="robot_description_kinematics")
    sub(kinematics, "rosparam", command="load", file=f"{package}/config/kinematics.yaml")
    move_group = sub(root, "group", ns="move_group")
    sub(move_group, "rosparam", command="load", file=f"{package}/config/moveit_controllers.yaml")
    sub(move_group, "param", name="allow_trajectory_execution", value="true")
    # move_group's planning pipeline, as the Setup Assistant configures it (OMPL with its default planners).
    sub(move_group, "param", name="planning_plugin", value="ompl_interface/OMPLPlanner")
    sub(move_group, "param", name="request_adapters", value=" ".join(REQUEST_ADAPTERS))
    sub(move_group, "param", name="start_state_max_bounds_error", value="0.1")
    return serialise(root)
