"""The registry of outputs: every file a built variant holds besides its assets, and the exporter that makes it.

Add a format by adding an entry here; the build writes each entry (``{robot}`` in a name is the variant's). An
entry that writes what MuJoCo measured on the model names the probe results it reads (``probes``); the pipeline runs
those probes (``svhdesc.compiler.probes``) before any output is written and hands their results in ``Built.probed``.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path
from typing import Any

from svhdesc.compiler.assets import Assets
from svhdesc.compiler.export import batch, ros2, ros2_control, ros2_launch, usd
from svhdesc.compiler.export.batch import Capacities
from svhdesc.compiler.export.mjcf import export_mjcf, export_scene
from svhdesc.compiler.export.moveit import (
    export_joint_limits,
    export_kinematics,
    export_moveit_controllers,
    export_moveit_launch,
    export_ros_controllers,
    export_srdf,
    planning_groups,
)
from svhdesc.compiler.export.package import export_package_xml, mesh_uri_prefix
from svhdesc.compiler.export.ros1 import export_connector, export_launch, export_node_script
from svhdesc.compiler.export.urdf import export_urdf
from svhdesc.ir import Robot
from svhdesc.model import BATCH_SCENE_FILE, NODE_SCRIPT, USD_FILE, batch_model_file

EXECUTABLE = 0o755


@dataclass(frozen=True)
class Probed:
    """What the probes measured on the compiled model in MuJoCo: a result is there when an output of the variant
    names it in its ``probes``, and reading one that is not raises (a batch model without capacities would still
    be a valid file)."""

    results: dict[str, Any] = field(default_factory=dict)  # name in PROBES -> result

    def _result(self, name: str) -> Any:
        if name not in self.results:
            raise LookupError(f"probe result {name!r} was not run: name it in the output's probes")
        return self.results[name]

    @property
    def damping(self) -> dict[str, float]:
        """Each position servo's velocity gain, as MuJoCo derives it from ``dampratio`` at compile time."""
        return self._result("damping")

    @property
    def collision_matrix(self) -> dict[tuple[str, str], str]:
        """The link pairs a planner may skip, and why (MoveIt's Setup Assistant's reasons)."""
        return self._result("collision_matrix")

    @property
    def capacities(self) -> Capacities:
        """The batch model's contact and constraint capacities, sized from sampled rollouts."""
        return self._result("capacities")


PROBES = ("damping", "collision_matrix", "capacities")


@dataclass
class Built:
    """What the exporters read: the compiled robot, its assets (already written under ``directory``/assets), and
    the probes' results."""

    robot: Robot
    assets: Assets
    directory: Path
    version: str  # svhdesc's, for package.xml
    probed: Probed = field(default_factory=Probed)

    @cached_property
    def mjcf(self) -> bytes:
        return export_mjcf(self.robot)

    @cached_property
    def ros2(self) -> Robot:
        """The robot as the ROS 2 files name it (hand joints as SCHUNK's ROS 2 driver names them)."""
        return ros2.ros2_robot(self.robot)


def _always(robot: Robot) -> bool:
    return True


def _moveit(robot: Robot) -> bool:
    """MoveIt's configuration plans an arm, a hand or both: a robot with neither gets none."""
    return bool(planning_groups(robot))


@dataclass(frozen=True)
class Output:
    name: str  # relative path; "{robot}" is the variant's name
    export: Callable[[Built], bytes]
    when: Callable[[Robot], bool] = _always
    stage: str = "export"  # its line in --timings
    executable: bool = False
    probes: tuple[str, ...] = ()  # the results of Probed it reads


def probes_wanted(robot: Robot) -> set[str]:
    """The probe results the outputs ``robot`` gets read."""
    return {name for output in OUTPUTS if output.when(robot) for name in output.probes}


OUTPUTS: tuple[Output, ...] = (
    Output("package.xml", lambda b: export_package_xml(b.robot, b.version)),
    Output("{robot}.urdf", lambda b: export_urdf(b.robot, mesh_uri_prefix(b.robot))),
    Output("{robot}.xml", lambda b: b.mjcf),
    Output("scene.xml", lambda b: export_scene(b.robot, f"{b.robot.name}.xml")),
    # Isaac Sim / Isaac Lab (PhysX) and Newton: the couplings as NewtonMimicAPI and PhysxMimicJointAPI.
    Output(USD_FILE, lambda b: usd.export_usd(b.robot, b.assets, b.probed.damping), stage="usd", probes=("damping",)),
    Output("config/connector.yaml", lambda b: export_connector(b.robot, b.probed.damping), probes=("damping",)),
    Output("launch/sim.launch", lambda b: export_launch(b.robot, f"{b.robot.name}.urdf")),
    Output(f"scripts/{NODE_SCRIPT}", lambda b: export_node_script(b.robot), executable=True),
    Output(
        "config/{robot}.srdf",
        lambda b: export_srdf(b.robot, b.probed.collision_matrix),
        _moveit,
        probes=("collision_matrix",),
    ),
    Output("config/kinematics.yaml", lambda b: export_kinematics(b.robot), _moveit),
    Output("config/joint_limits.yaml", lambda b: export_joint_limits(b.robot), _moveit),
    Output("config/moveit_controllers.yaml", lambda b: export_moveit_controllers(b.robot), _moveit),
    Output(
        "config/ros_controllers.yaml",
        lambda b: export_ros_controllers(b.robot, b.probed.damping),
        _moveit,
        probes=("damping",),
    ),
    Output("launch/moveit.launch", lambda b: export_moveit_launch(b.robot), _moveit),
    # ROS 2 (Jazzy): an ament package in ros2/ whose share directory is the variant folder.
    Output("ros2/package.xml", lambda b: ros2.export_package_xml(b.ros2, b.version)),
    Output("ros2/CMakeLists.txt", lambda b: ros2.export_cmakelists(b.ros2)),
    Output("ros2/urdf/{robot}.urdf.xacro", lambda b: ros2_control.export_urdf_xacro(b.ros2)),
    Output("ros2/urdf/{robot}.ros2_control.xacro", lambda b: ros2_control.export_ros2_control(b.ros2)),
    Output("ros2/mujoco/{robot}.xml", lambda b: ros2_control.export_mujoco_model(b.ros2)),
    Output("ros2/mujoco/scene.xml", lambda b: ros2_control.export_mujoco_scene(b.ros2)),
    Output("ros2/config/ros2_controllers.yaml", lambda b: ros2.export_controllers(b.ros2)),
    Output(
        "ros2/config/forward_position_controller.yaml",
        lambda b: ros2.export_forward_fragment(b.ros2),
        lambda robot: bool(ros2.forward_controllers(robot)),
    ),
    Output("ros2/launch/sim.launch.py", lambda b: ros2_launch.export_sim_launch(b.ros2)),
    Output("ros2/launch/svhdesc.launch.py", lambda b: ros2_launch.export_svhdesc_launch(b.ros2)),
    Output(
        "ros2/config/{robot}.srdf",
        lambda b: export_srdf(b.ros2, b.probed.collision_matrix),
        _moveit,
        probes=("collision_matrix",),
    ),
    Output("ros2/config/kinematics.yaml", lambda b: export_kinematics(b.ros2), _moveit),
    Output("ros2/config/joint_limits.yaml", lambda b: export_joint_limits(b.ros2), _moveit),
    Output("ros2/config/moveit_controllers.yaml", lambda b: ros2.export_moveit_controllers(b.ros2), _moveit),
    Output("ros2/launch/moveit.launch.py", lambda b: ros2_launch.export_moveit_launch(b.ros2), _moveit),
    Output(
        batch_model_file("{robot}"),
        lambda b: batch.export_batch(b.robot, b.probed.capacities),
        stage="batch",
        probes=("capacities",),
    ),
    Output(BATCH_SCENE_FILE, lambda b: batch.export_batch_scene(b.robot), stage="batch"),
)
