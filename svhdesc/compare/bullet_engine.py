"""Bullet (pybullet): the URDF through ``svhdesc.loaders.load_pybullet`` (JOINT_GEAR couplings), plus the surface.

Servos are pybullet's own POSITION_CONTROL motors (a velocity constraint with an impulse bound: the way
pybullet users drive a robot) with the model's effort limits and pybullet's default gains. Bullet
multiplies the two friction coefficients of a contact, so the surface gets 1 and the fingertip the
experiment's friction.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from svhdesc.compare.engine import Engine, RunConfig

POSITION_GAIN = 0.1  # pybullet's defaults for POSITION_CONTROL
VELOCITY_GAIN = 1.0
# Motors, gears and contacts share one constraint island: with pybullet's default 50 iterations the index
# finger's gear (j14) lags 13 mrad before contact; 150 bring it to 2e-5 rad.
SOLVER_ITERATIONS = 150


class BulletEngine(Engine):
    name = "bullet"
    module = "pybullet"
    install = "pip install pybullet"

    def load(self, config: RunConfig) -> None:
        import pybullet as p

        from svhdesc.loaders import load_pybullet

        self.p = p
        self.client = p.connect(p.DIRECT)
        self.robot = load_pybullet(config.variant, client=self.client)
        client, body = self.client, self.robot.body
        self._dt = config.timestep
        p.setTimeStep(self._dt, physicsClientId=client)
        p.setPhysicsEngineParameter(numSolverIterations=SOLVER_ITERATIONS, physicsClientId=client)
        p.setGravity(0.0, 0.0, -9.81, physicsClientId=client)
        setup = config.setup
        surface = setup.surface
        shape = p.createCollisionShape(p.GEOM_BOX, halfExtents=list(surface.half_size), physicsClientId=client)
        w, x, y, z = surface.quat
        self.surface = p.createMultiBody(
            baseMass=0.0,
            baseCollisionShapeIndex=shape,
            basePosition=list(surface.position),
            baseOrientation=[x, y, z, w],
            physicsClientId=client,
        )
        self.tip = self.robot.links[setup.fingertip]
        p.changeDynamics(self.surface, -1, lateralFriction=1.0, physicsClientId=client)
        p.changeDynamics(body, self.tip, lateralFriction=setup.friction, physicsClientId=client)
        if config.mass is not None:
            for link, index in self.robot.links.items():
                if link in config.mass_links:
                    p.changeDynamics(body, index, mass=config.mass, physicsClientId=client)
        if config.inertia is not None:
            for link, index in self.robot.links.items():
                if link in config.finger_links:
                    p.changeDynamics(body, index, localInertiaDiagonal=[config.inertia] * 3, physicsClientId=client)
        self.indices = [self.robot.joints[name] for name in setup.joints]
        for index, q in zip(self.indices, setup.home_qpos, strict=True):
            p.resetJointState(body, index, float(q), 0.0, physicsClientId=client)
        self.actuated = [self.robot.joints[name] for name in setup.actuated]
        self.forces = [float(f) for f in config.servo.limit]

    def step(self, targets: np.ndarray) -> None:
        p = self.p
        p.setJointMotorControlArray(
            self.robot.body,
            self.actuated,
            p.POSITION_CONTROL,
            targetPositions=[float(t) for t in targets],
            forces=self.forces,
            positionGains=[POSITION_GAIN] * len(self.actuated),
            velocityGains=[VELOCITY_GAIN] * len(self.actuated),
            physicsClientId=self.client,
        )
        p.stepSimulation(physicsClientId=self.client)

    def joint_positions(self) -> np.ndarray:
        states = self.p.getJointStates(self.robot.body, self.indices, physicsClientId=self.client)
        return np.array([s[0] for s in states])

    def fingertip_force(self) -> float:
        contacts = self.p.getContactPoints(
            bodyA=self.robot.body, bodyB=self.surface, linkIndexA=self.tip, physicsClientId=self.client
        )
        return float(sum(c[9] for c in contacts))

    def fingertip_force_vector(self) -> np.ndarray:
        contacts = self.p.getContactPoints(
            bodyA=self.robot.body, bodyB=self.surface, linkIndexA=self.tip, physicsClientId=self.client
        )
        # contactNormalOnB points from the surface (B) to the fingertip (A): the normal force on A.
        total = np.zeros(3)
        for c in contacts:
            total += c[9] * np.array(c[7]) + c[10] * np.array(c[11]) + c[12] * np.array(c[13])
        return total

    def fingertip_position(self) -> np.ndarray:
        state = self.p.getLinkState(
            self.robot.body, self.tip, computeForwardKinematics=True, physicsClientId=self.client
        )
        return np.array(state[4])

    @property
    def timestep(self) -> float:
        return self._dt

    def settings(self) -> dict[str, Any]:
        params = self.p.getPhysicsEngineParameters(physicsClientId=self.client)
        return {
            "version": self.version(),
            "timestep": params["fixedTimeStep"],
            "solver": "sequential impulse (btMultiBody)",
            "iterations": params["numSolverIterations"],
            "couplings": "JOINT_GEAR constraints (svhdesc.loaders)",
            "servo": f"POSITION_CONTROL motors, gains {POSITION_GAIN}/{VELOCITY_GAIN}, force = effort limit "
            "(a velocity constraint: it holds against gravity without a feedforward)",
            "friction": "product of the two bodies' coefficients (surface 1, fingertip the model's)",
            "armature": "none (URDF)",
        }

    def close(self) -> None:
        if getattr(self, "client", None) is not None:
            self.p.disconnect(physicsClientId=self.client)
            self.client = None
