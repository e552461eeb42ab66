"""The ROS files of a variant (connector, launch, node script; MoveIt config): figures that need
the compiled MJCF are measured here, then the exporters render them."""

from __future__ import annotations

from .export.ros import export_connector, export_launch, export_node_script
from .interfaces import NODE_SCRIPT
from .ir import Robot
from .stages.assets import Assets

EXECUTABLE = 0o755


def servo_damping(mjcf: bytes, assets: Assets) -> dict[str, float]:
    """Each position servo's velocity gain, as MuJoCo derives it from ``dampratio`` at compile time."""
    import mujoco

    model = mujoco.MjModel.from_xml_string(mjcf.decode(), {f"assets/{k}": v for k, v in assets.files.items()})
    return {model.actuator(a).name: float(-model.actuator_biasprm[a, 2]) for a in range(model.nu)}


def ros_outputs(robot: Robot, mjcf: bytes, assets: Assets) -> dict[str, bytes]:
    """Relative path -> content; paths under scripts/ are executables."""
    return {
        "config/connector.yaml": export_connector(robot, servo_damping(mjcf, assets)),
        "launch/sim.launch": export_launch(robot, f"{robot.name}.urdf"),
        f"scripts/{NODE_SCRIPT}": export_node_script(robot),
    }
