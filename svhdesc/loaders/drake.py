"""Drake (PyPI ``drake``): a discrete MultibodyPlant with the SAP solver, where <mimic> becomes a
coupler constraint (Drake ignores <mimic> for any other plant).

    robot = load_drake("svh_right", pd_gains={"right_hand_Pinky": (10.0, 0.1)})
    diagram = robot.builder.Build()
    # feed robot.plant.get_desired_state_input_port(robot.instance) for the PD-controlled actuators

Drake collides every pair of bodies but parent and child: the loader applies the MJCF's contact
exclusions (adjacent links, and pairs that touch at rest). Drake only collides OBJ/VTK/glTF meshes:
the build writes every collision mesh as OBJ (visuals stay STL, which Drake accepts for illustration).
Pitfalls (drake 1.51): the plant must be SAP *before* parsing; PdControllerGains lives in
pydrake.multibody.tree; GetJointActuatorIndices(instance) is empty until Finalize.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

from svhdesc.loaders._common import absolute_urdf, contact_excludes, require


@dataclass
class DrakeRobot:
    builder: Any  # pydrake.systems.framework.DiagramBuilder, not yet built
    plant: Any  # MultibodyPlant, finalized
    scene_graph: Any  # SceneGraph
    instance: Any  # ModelInstanceIndex of the variant


def load_drake(
    name: str = "ur5_svh_right",
    time_step: float = 1e-3,
    pd_gains: Mapping[str, tuple[float, float]] | None = None,
    builder: Any = None,
    before_finalize: Callable[[Any, Any], None] | None = None,
) -> DrakeRobot:
    """Plant and scene graph in ``builder`` (a new DiagramBuilder if None), finalized.

    ``pd_gains`` (joint name -> (kp, kd)) makes those joints' actuators Drake's implicit PD
    controllers, driven through the plant's desired-state input port; the rest take torques.
    ``before_finalize(plant, instance)`` runs just before ``Finalize()``: Drake registers geometry
    (a table, a contact surface) only until then.
    """
    if time_step <= 0:
        raise ValueError("Drake's coupler constraints need a discrete plant: time_step > 0")
    require("pydrake", "load_drake")
    from pydrake.multibody.parsing import Parser
    from pydrake.multibody.plant import AddMultibodyPlant, MultibodyPlantConfig
    from pydrake.multibody.tree import JointActuatorIndex, PdControllerGains
    from pydrake.systems.framework import DiagramBuilder

    builder = builder or DiagramBuilder()
    # The contact approximation must be SAP before parsing, or the parser drops <mimic> with a warning.
    config = MultibodyPlantConfig(time_step=time_step, discrete_contact_approximation="sap")
    plant, scene_graph = AddMultibodyPlant(config, builder)
    (instance,) = Parser(plant).AddModels(str(absolute_urdf(name)))
    gains = dict(pd_gains or {})
    for index in range(plant.num_actuators()):  # GetJointActuatorIndices is empty before Finalize
        actuator = plant.get_joint_actuator(JointActuatorIndex(index))
        if actuator.model_instance() == instance and actuator.joint().name() in gains:
            kp, kd = gains.pop(actuator.joint().name())
            actuator.set_controller_gains(PdControllerGains(p=kp, d=kd))
    if gains:
        raise KeyError(f"no actuated joint named {', '.join(sorted(gains))}")
    if before_finalize is not None:
        before_finalize(plant, instance)
    plant.Finalize()
    _exclude_contacts(name, plant, scene_graph)
    return DrakeRobot(builder, plant, scene_graph, instance)


def _exclude_contacts(name: str, plant: Any, scene_graph: Any) -> None:
    """Apply the MJCF's contact exclusions: Drake collides every non-adjacent pair of bodies."""
    from pydrake.geometry import CollisionFilterDeclaration, GeometrySet

    declaration = CollisionFilterDeclaration()
    for first, second in contact_excludes(name):
        if plant.HasBodyNamed(first) and plant.HasBodyNamed(second):
            a = plant.GetCollisionGeometriesForBody(plant.GetBodyByName(first))
            b = plant.GetCollisionGeometriesForBody(plant.GetBodyByName(second))
            declaration.ExcludeBetween(GeometrySet(a), GeometrySet(b))
    scene_graph.collision_filter_manager().Apply(declaration)
