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


# The controllers' default `constraints` (JointTrajectoryController parameters): ur_robot_driver's
# values for the arm; tighter goals for the hand, whose joints are short and light. The node uses
# them unless /<controller>/constraints/... are set; ros_controllers.yaml carries the same values.
CONSTRAINTS = {
    "hand": {"goal": 0.01, "trajectory": 0.0, "goal_time": 1.0, "stopped_velocity_tolerance": 0.05},
    "arm": {"goal": 0.1, "trajectory": 0.2, "goal_time": 0.6, "stopped_velocity_tolerance": 0.05},
}
