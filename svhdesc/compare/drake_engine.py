"""Drake: the URDF through ``svhdesc.loaders.load_drake`` (discrete plant, SAP solver, <mimic> as coupler
constraints), plus the surface registered on the world body before the plant is finalized.

Servos: Drake's PD-controlled actuators (implicit in SAP, clamped to the URDF effort limits) with the
gains of ``engine.Servo``, plus gravity compensation fed forward through the actuation port (the MJCF's
servos compensate gravity too). Drake combines two friction coefficients as 2 a b / (a + b): surface and
fingertip both get the experiment's.
"""

from __future__ import annotations

import inspect
from typing import Any

import numpy as np

from svhdesc.compare.engine import Engine, RunConfig
from svhdesc.compare.experiment import SURFACE

HOOK = "before_finalize"  # load_drake's callback for geometry that must exist before Finalize()


class DrakeEngine(Engine):
    name = "drake"
    module = "pydrake"
    install = "pip install drake"
    distribution = "drake"

    def load(self, config: RunConfig) -> None:
        from pydrake.multibody.tree import RotationalInertia, SpatialInertia
        from pydrake.systems.analysis import Simulator

        from svhdesc.loaders import load_drake

        if HOOK not in inspect.signature(load_drake).parameters:
            raise RuntimeError(f"svhdesc.loaders.load_drake has no {HOOK}= hook to add the surface with")
        setup = config.setup
        gains = {name: (float(kp), float(kv)) for name, kp, kv in zip(setup.actuated, *_gains(config), strict=True)}
        robot = load_drake(
            config.variant,
            time_step=config.timestep,
            pd_gains=gains,
            **{HOOK: lambda plant, instance: self._surface(plant, setup)},
        )
        self.plant, self.instance = plant, instance = robot.plant, robot.instance
        self.tip_friction = _friction(robot.scene_graph, plant, setup.fingertip, instance)
        self.diagram = robot.builder.Build()
        self.simulator = Simulator(self.diagram)
        self.context = self.simulator.get_mutable_context()
        self.plant_context = plant.GetMyMutableContextFromRoot(self.context)
        self.tip = plant.GetBodyByName(setup.fingertip, instance)
        for link in config.finger_links | config.mass_links:
            if not plant.HasBodyNamed(link, instance):
                continue
            body = plant.GetBodyByName(link, instance)
            mass = config.mass if config.mass is not None and link in config.mass_links else body.default_mass()
            if config.inertia is not None and link in config.finger_links:
                rotational = RotationalInertia(*([config.inertia] * 3))
            else:  # the URDF's, scaled with the mass
                unit = body.default_spatial_inertia().get_unit_inertia()
                rotational = unit.ShiftToCenterOfMass(body.default_com()) * mass
                if mass == body.default_mass():
                    continue
            inertia = SpatialInertia.MakeFromCentralInertia(mass, body.default_com(), rotational)
            body.SetSpatialInertiaInBodyFrame(self.plant_context, inertia)
        self.starts = [plant.GetJointByName(name, instance).position_start() for name in setup.joints]
        q = plant.GetPositions(self.plant_context)
        q[self.starts] = setup.home_qpos
        plant.SetPositions(self.plant_context, q)
        # The desired-state port lists the instance's PD actuators in actuator order: [q_d..., v_d...].
        order = [plant.get_joint_actuator(i).joint().name() for i in plant.GetJointActuatorIndices(instance)]
        self.order = np.array([setup.actuated.index(name) for name in order])
        self.port = plant.get_desired_state_input_port(instance)
        self.actuation = plant.get_actuation_input_port(instance)
        self.actuator_dofs = [
            plant.get_joint_actuator(i).joint().velocity_start() for i in plant.GetJointActuatorIndices(instance)
        ]
        self.zeros = np.zeros(len(order))
        self._dt = config.timestep
        self._time = 0.0
        self.simulator.Initialize()

    def _surface(self, plant: Any, setup: Any) -> None:
        from pydrake.geometry import Box
        from pydrake.math import RigidTransform, RotationMatrix
        from pydrake.multibody.plant import CoulombFriction

        surface = setup.surface
        size = 2.0 * np.asarray(surface.half_size)
        pose = RigidTransform(RotationMatrix(np.asarray(surface.rotation)), np.asarray(surface.position))
        friction = CoulombFriction(setup.friction, setup.friction)
        self.box = plant.RegisterCollisionGeometry(plant.world_body(), pose, Box(*size), SURFACE, friction)

    def step(self, targets: np.ndarray) -> None:
        self.port.FixValue(self.plant_context, np.concatenate([targets[self.order], self.zeros]))
        # Gravity compensation, as the MJCF's servos have it: Drake adds this feedforward to the PD
        # output (and clamps the sum to the effort limit).
        gravity = self.plant.CalcGravityGeneralizedForces(self.plant_context)
        self.actuation.FixValue(self.plant_context, -gravity[self.actuator_dofs])
        self._time += self._dt
        self.simulator.AdvanceTo(self._time)

    def joint_positions(self) -> np.ndarray:
        return self.plant.GetPositions(self.plant_context)[self.starts]

    def fingertip_force(self) -> float:
        results = self.plant.get_contact_results_output_port().Eval(self.plant_context)
        tip, world = self.tip.index(), self.plant.world_body().index()
        total = 0.0
        for i in range(results.num_point_pair_contacts()):
            info = results.point_pair_contact_info(i)
            if {info.bodyA_index(), info.bodyB_index()} == {tip, world}:
                total += abs(float(np.dot(info.contact_force(), info.point_pair().nhat_BA_W)))
        for i in range(results.num_hydroelastic_contacts()):
            info = results.hydroelastic_contact_info(i)
            surface = info.contact_surface()
            ids = {surface.id_M(), surface.id_N()}
            if self.box in ids:
                total += abs(float(info.F_Ac_W().translational() @ surface.face_normal(0)))
        return total

    def fingertip_force_vector(self) -> np.ndarray:
        results = self.plant.get_contact_results_output_port().Eval(self.plant_context)
        tip, world = self.tip.index(), self.plant.world_body().index()
        total = np.zeros(3)
        for i in range(results.num_point_pair_contacts()):
            info = results.point_pair_contact_info(i)
            if {info.bodyA_index(), info.bodyB_index()} == {tip, world}:
                # contact_force() acts on body B.
                force = np.asarray(info.contact_force())
                total += force if info.bodyB_index() == tip else -force
        for i in range(results.num_hydroelastic_contacts()):
            info = results.hydroelastic_contact_info(i)
            surface = info.contact_surface()
            if self.box in {surface.id_M(), surface.id_N()}:
                force = np.asarray(info.F_Ac_W().translational())  # on the body of geometry M
                total += -force if surface.id_M() == self.box else force
        return total

    def fingertip_position(self) -> np.ndarray:
        return np.array(self.plant.EvalBodyPoseInWorld(self.plant_context, self.tip).translation())

    @property
    def timestep(self) -> float:
        return float(self.plant.time_step())

    def settings(self) -> dict[str, Any]:
        plant = self.plant
        return {
            "version": self.version(),
            "timestep": float(plant.time_step()),
            "solver": f"discrete, {plant.get_discrete_contact_approximation()}".replace(
                "DiscreteContactApproximation.k", ""
            ),
            "contact_model": str(plant.get_contact_model()).replace("ContactModel.k", ""),
            "couplings": "SAP coupler constraints (svhdesc.loaders)",
            "servo": "PD-controlled actuators (implicit in SAP, kp, kv from the model) + gravity feedforward, "
            "effort limits",
            "friction": f"2ab/(a+b) of the two geometries (surface the experiment's, fingertip {self.tip_friction})",
            "armature": "none (URDF)",
        }


def _friction(scene_graph: Any, plant: Any, link: str, instance: Any) -> str:
    """The fingertip's sliding friction as parsed (the loader's; Drake's default is 1)."""
    inspector = scene_graph.model_inspector()
    values = set()
    for geometry in plant.GetCollisionGeometriesForBody(plant.GetBodyByName(link, instance)):
        properties = inspector.GetProximityProperties(geometry)
        if properties is not None and properties.HasProperty("material", "coulomb_friction"):
            values.add(properties.GetProperty("material", "coulomb_friction").dynamic_friction())
    return ", ".join(f"{v:g}" for v in sorted(values)) or "?"


def _gains(config: RunConfig) -> tuple[np.ndarray, np.ndarray]:
    return config.servo.kp, config.servo.kv
