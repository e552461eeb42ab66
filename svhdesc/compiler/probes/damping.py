"""The position servos' velocity gains, as MuJoCo derives them from ``dampratio`` when it compiles the model."""

from __future__ import annotations

from svhdesc.compiler.assets import Assets
from svhdesc.compiler.export.mjcf import export_mjcf
from svhdesc.ir import Robot


def servo_damping(robot: Robot, assets: Assets) -> dict[str, float]:
    """Actuator name -> its velocity gain (the negated third bias parameter MuJoCo compiles)."""
    import mujoco

    files = {f"assets/{k}": v for k, v in assets.files.items()}
    model = mujoco.MjModel.from_xml_string(export_mjcf(robot).decode(), files)
    return {model.actuator(a).name: float(-model.actuator_biasprm[a, 2]) for a in range(model.nu)}
