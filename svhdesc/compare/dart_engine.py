"""DART (dartpy, Gazebo Sim's default engine): the URDF through ``svhdesc.loaders.load_dart`` (mimic joints
as DART's MIMIC actuators), plus the surface as a welded one-body skeleton.

Servos: DART's joint spring and damper, which it integrates implicitly, used as a PD servo: stiffness
kp, rest position = target, damping = the URDF's joint damping + kv (the gains of ``engine.Servo``),
plus gravity compensation g(q) as a joint force on the actuated joints (the MJCF's servos compensate
gravity too).
DART bounds no spring force, so the effort limit is not applied. Joint position limits are switched on
(DART's URDF loader leaves them off); velocity limits stay off, as in the other engines. DART takes the
smaller friction coefficient of a contact: surface and fingertip both get the experiment's.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from svhdesc.compare.engine import Engine, RunConfig


class DartEngine(Engine):
    name = "dart"
    module = "dartpy"
    install = "pip install dartpy"

    def load(self, config: RunConfig) -> None:
        import dartpy as dart

        from svhdesc.loaders import load_dart

        setup = config.setup
        # DART's own MIMIC actuators (what its URDF loader makes of <mimic>): the loader's two-way
        # coupler constraint trails its channel here (0.2 rad behind on the pinky within 0.4 s, held
        # to the followers' velocity limits), while the MIMIC servo tracks to 1e-4 rad.
        self.skeleton = skeleton = load_dart(config.variant, coupler=False)
        self.world = world = dart.simulation.World()
        world.setTimeStep(config.timestep)
        world.setGravity([0.0, 0.0, -9.81])
        world.addSkeleton(skeleton)
        world.addSkeleton(self._surface(dart, setup))

        self.tip = skeleton.getBodyNode(setup.fingertip)
        for shape in self.tip.getShapeNodes():
            if shape.hasDynamicsAspect():
                shape.getDynamicsAspect().setFrictionCoeff(setup.friction)
        if config.mass is not None:
            for index in range(skeleton.getNumBodyNodes()):
                body = skeleton.getBodyNode(index)
                if body.getName() in config.mass_links:
                    body.setMass(config.mass)
        if config.inertia is not None:
            value = config.inertia
            for index in range(skeleton.getNumBodyNodes()):
                body = skeleton.getBodyNode(index)
                if body.getName() in config.finger_links:
                    body.setMomentOfInertia(value, value, value, 0.0, 0.0, 0.0)
        self.joints = [skeleton.getJoint(name) for name in setup.joints]
        for joint, q in zip(self.joints, setup.home_qpos, strict=True):
            # Enforcing limits in DART enforces velocity limits too; the other engines (and the MJCF)
            # have none, and a coupled joint capped at 1 rad/s would trail its channel.
            joint.setLimitEnforcement(True)
            joint.setVelocityLowerLimit(0, -np.inf)
            joint.setVelocityUpperLimit(0, np.inf)
            joint.setPosition(0, float(q))
            joint.setVelocity(0, 0.0)
        self.servos = [skeleton.getJoint(name) for name in setup.actuated]
        self.servo_dofs = [joint.getIndexInSkeleton(0) for joint in self.servos]
        for joint, kp, kv in zip(self.servos, config.servo.kp, config.servo.kv, strict=True):
            joint.setSpringStiffness(0, float(kp))
            joint.setDampingCoefficient(0, joint.getDampingCoefficient(0) + float(kv))
        self._dt = config.timestep

    def _surface(self, dart: Any, setup: Any) -> Any:
        surface = setup.surface
        skeleton = dart.dynamics.Skeleton("svhdesc_contact_surface")
        joint, body = skeleton.createWeldJointAndBodyNodePair()
        placement = dart.math.Isometry3()
        placement.set_rotation(np.asarray(surface.rotation))
        placement.set_translation(np.asarray(surface.position))
        joint.setTransformFromParentBodyNode(placement)
        shape = body.createShapeNode(dart.dynamics.BoxShape(2.0 * np.asarray(surface.half_size)))
        shape.createCollisionAspect()
        shape.createDynamicsAspect().setFrictionCoeff(setup.friction)
        skeleton.setMobile(False)
        self.surface_body = body
        return skeleton

    def step(self, targets: np.ndarray) -> None:
        # Gravity compensation, as the MJCF's servos have it: the actuated joints carry g(q).
        gravity = self.skeleton.getGravityForces()
        for joint, dof, target in zip(self.servos, self.servo_dofs, targets, strict=True):
            joint.setRestPosition(0, float(target))
            joint.setForce(0, float(gravity[dof]))
        self.world.step()

    def joint_positions(self) -> np.ndarray:
        return np.array([joint.getPosition(0) for joint in self.joints])

    def fingertip_force(self) -> float:
        result = self.world.getLastCollisionResult()
        total = 0.0
        for contact in result.getContacts():
            bodies = {
                contact.collisionObject1.getShapeFrame().asShapeNode().getBodyNodePtr().getName(),
                contact.collisionObject2.getShapeFrame().asShapeNode().getBodyNodePtr().getName(),
            }
            if bodies == {self.tip.getName(), self.surface_body.getName()}:
                total += abs(float(np.dot(contact.force, contact.normal)))
        return total

    def fingertip_force_vector(self) -> np.ndarray:
        result = self.world.getLastCollisionResult()
        total = np.zeros(3)
        for contact in result.getContacts():
            first = contact.collisionObject1.getShapeFrame().asShapeNode().getBodyNodePtr().getName()
            second = contact.collisionObject2.getShapeFrame().asShapeNode().getBodyNodePtr().getName()
            if {first, second} == {self.tip.getName(), self.surface_body.getName()}:
                # DART's contact force acts on the first object.
                force = np.asarray(contact.force, dtype=float)
                total += force if first == self.tip.getName() else -force
        return total

    def fingertip_position(self) -> np.ndarray:
        return np.array(self.tip.getWorldTransform().translation())

    @property
    def timestep(self) -> float:
        return float(self.world.getTimeStep())

    def settings(self) -> dict[str, Any]:
        solver = self.world.getConstraintSolver()
        return {
            "version": self.version(),
            "timestep": float(self.world.getTimeStep()),
            "solver": type(solver).__name__,
            "collision": self.world.getCollisionDetector().getType(),
            "split_impulse": bool(solver.isSplitImpulseEnabled()),
            "couplings": "MIMIC actuators (svhdesc.loaders, coupler=False)",
            "servo": "implicit joint spring + damper (kp, kv from the model) + gravity feedforward, no effort limit",
            "friction": "min of the two shapes' coefficients (both the experiment's)",
            "armature": "none (URDF)",
            "limits": "position enforced, velocity not",
        }
