"""Names the real drivers use, shared by the exporters (ROS/MoveIt config) and the runtime (node).

SCHUNK's ROS 1 SVH driver runs a JointTrajectoryController `<prefix>_controller` over its nine
channels; ur_robot_driver runs `scaled_pos_joint_traj_controller` over the six arm joints.
"""

from __future__ import annotations

# The SVH driver's channels, in its order; the hand's actuated joints are named <prefix>_<channel>.
DRIVER_CHANNELS = (
    "Thumb_Flexion",
    "Thumb_Opposition",
    "Index_Finger_Distal",
    "Index_Finger_Proximal",
    "Middle_Finger_Distal",
    "Middle_Finger_Proximal",
    "Ring_Finger",
    "Pinky",
    "Finger_Spread",
)
ARM_CONTROLLER = "scaled_pos_joint_traj_controller"
ACTION = "follow_joint_trajectory"
NODE_NAME = "svhdesc_sim"
NODE_SCRIPT = "svhdesc_sim"  # the executable in each variant's scripts/ that roslaunch starts
CONNECTOR_ROOT = "/mujoco"


def hand_controller(prefix: str) -> str:
    return f"{prefix}_controller"


def connector_topics(joint: str) -> dict[str, str]:
    """Topics of the thesis' connector file for ``joint`` (control in, pose out, initpose in)."""
    return {
        "control_topic": f"{CONNECTOR_ROOT}/{joint}/control",
        "pose_topic": f"{CONNECTOR_ROOT}/{joint}/pose",
        "initpose_topic": f"{CONNECTOR_ROOT}/{joint}/initpose",
    }


# JointTrajectoryController's own defaults where a config declares no `constraints`
# (ros_controllers tolerances.h, getSegmentTolerances).
JTC_DEFAULTS = {"goal": 0.0, "trajectory": 0.0, "goal_time": 0.0, "stopped_velocity_tolerance": 0.01}

# Each controller's default `constraints` as its real driver configures them. SCHUNK's
# schunk_svh_driver (cfg/right_hand_controllers.yaml) declares none, so the hand gets the JTC defaults
# above: no position check, only |velocity| <= 0.01 rad/s when the trajectory ends. ur_robot_driver
# (config/ur5_controllers.yaml) sets the arm's. The node uses them unless /<controller>/constraints/...
# are set; ros_controllers.yaml carries the same (no `constraints:` for the hand, as SCHUNK's file).
CONSTRAINTS = {
    "hand": dict(JTC_DEFAULTS),
    "arm": {"goal": 0.1, "trajectory": 0.2, "goal_time": 0.6, "stopped_velocity_tolerance": 0.05},
}
DECLARES_CONSTRAINTS = {"hand": False, "arm": True}
# state_publish_rate / action_monitor_rate: SCHUNK's config leaves the JTC defaults (50 / 20 Hz);
# ur5_controllers.yaml sets 125 (its loop_hz) / 10.
STATE_PUBLISH_RATE = {"hand": 50.0, "arm": 125.0}
ACTION_MONITOR_RATE = {"hand": 20.0, "arm": 10.0}
# SCHUNK's SVHRosControlHWInterface registers joint velocities but never writes them (always 0), so
# its controller's stopped-velocity check always passes; ur_robot_driver reports measured velocities.
REPORTS_VELOCITY = {"hand": False, "arm": True}

# The controllers each real driver loads (ur5_bringup.launch: `controllers` are started,
# `stopped_controllers` loaded and stopped), as /controller_manager/list_controllers reports them.
# Only the ones the simulation implements are listed: see README (ROS node, deviations).
JOINT_STATE_CONTROLLER = "joint_state_controller"
ARM_STOPPED_CONTROLLER = "pos_joint_traj_controller"
ARM_VELOCITY_CONTROLLER = "joint_group_vel_controller"
CONTROLLER_TYPES = {
    JOINT_STATE_CONTROLLER: "joint_state_controller/JointStateController",
    ARM_CONTROLLER: "position_controllers/ScaledJointTrajectoryController",
    ARM_STOPPED_CONTROLLER: "position_controllers/JointTrajectoryController",
    ARM_VELOCITY_CONTROLLER: "velocity_controllers/JointGroupVelocityController",
    "hand": "position_controllers/JointTrajectoryController",
}
