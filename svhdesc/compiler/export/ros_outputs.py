"""The ROS files of a variant (connector, launch, node script; MoveIt config): figures that need
the compiled MJCF are measured here, then the exporters render them."""

from __future__ import annotations

from svhdesc.compiler.export.moveit import (
    export_joint_limits,
    export_kinematics,
    export_moveit_controllers,
    export_moveit_launch,
    export_ros_controllers,
    export_srdf,
)
from svhdesc.compiler.export.ros import export_connector, export_launch, export_node_script
from svhdesc.compiler.stages.assets import Assets
from svhdesc.compiler.stages.collision_matrix import collision_matrix
from svhdesc.ir import Robot
from svhdesc.model import NODE_SCRIPT

EXECUTABLE = 0o755


def servo_damping(mjcf: bytes, assets: Assets) -> dict[str, float]:
    """Each position servo's velocity gain, as MuJoCo derives it from ``dampratio`` at compile time."""
    import mujoco

    model = mujoco.MjModel.from_xml_string(mjcf.decode(), {f"assets/{k}": v for k, v in assets.files.items()})
    return {model.actuator(a).name: float(-model.actuator_biasprm[a, 2]) for a in range(model.nu)}


def ros_outputs(robot: Robot, mjcf: bytes, assets: Assets) -> dict[str, bytes]:
    """Relative path -> content; paths under scripts/ are executables."""
    damping = servo_damping(mjcf, assets)
    outputs = {
        "config/connector.yaml": export_connector(robot, damping),
        "launch/sim.launch": export_launch(robot, f"{robot.name}.urdf"),
        f"scripts/{NODE_SCRIPT}": export_node_script(robot),
    }
    if robot.channels:
        outputs.update(
            {
                f"config/{robot.name}.srdf": export_srdf(robot, collision_matrix(robot, assets)),
                "config/kinematics.yaml": export_kinematics(robot),
                "config/joint_limits.yaml": export_joint_limits(robot),
                "config/moveit_controllers.yaml": export_moveit_controllers(robot),
                "config/ros_controllers.yaml": export_ros_controllers(robot, damping),
                "launch/moveit.launch": export_moveit_launch(robot),
            }
        )
    return outputs
