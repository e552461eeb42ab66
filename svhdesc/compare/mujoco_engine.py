"""MuJoCo: the generated MJCF as it is (its actuators, equalities, solver options), plus the surface."""

from __future__ import annotations

from typing import Any

import numpy as np

from svhdesc.compare import experiment
from svhdesc.compare.engine import Engine, RunConfig, Servo
from svhdesc.model import HandId


def _spec(
    mjcf_path: Any,
    inertia: float | None,
    finger_links: frozenset[str],
    mass: float | None = None,
    mass_links: frozenset[str] = frozenset(),
) -> Any:
    """The MJCF as an MjSpec, finger links given a diagonal inertia and ``mass_links`` a mass when asked."""
    import mujoco

    spec = mujoco.MjSpec.from_file(str(mjcf_path))
    if mass is not None:
        for body in spec.bodies:
            if body.name in mass_links:
                body.mass = mass
    if inertia is not None:
        for body in spec.bodies:
            if body.name not in finger_links:
                continue
            # MuJoCo rejects a body with both: set whichever form the MJCF used.
            if np.isfinite(body.fullinertia[0]):
                body.fullinertia = [inertia, inertia, inertia, 0.0, 0.0, 0.0]
            else:
                body.inertia = [inertia, inertia, inertia]
                body.iquat = [1.0, 0.0, 0.0, 0.0]
    return spec


def finger_links(mjcf_path: Any, hand_id: HandId | None) -> frozenset[str]:
    """Bodies moved by a joint of the built model's hand ``hand_id``, the links the thesis' sweep changes."""
    import mujoco

    model = mujoco.MjModel.from_xml_path(str(mjcf_path))
    owns = hand_id.owns if hand_id is not None else lambda name: False
    hand = {int(model.jnt_bodyid[j]) for j in range(model.njnt) if owns(model.joint(j).name)}
    result = set()
    for body in range(1, model.nbody):
        ancestor = body
        while ancestor > 0 and ancestor not in hand:
            ancestor = int(model.body_parentid[ancestor])
        if ancestor > 0 and model.body_mass[body] > 0:
            result.add(model.body(body).name)
    return frozenset(result)


def hand_links(mjcf_path: Any, hand_id: HandId | None) -> frozenset[str]:
    """Every body with mass of the built model's hand ``hand_id``: the links the thesis gives 0.01 kg each."""
    import mujoco

    model = mujoco.MjModel.from_xml_path(str(mjcf_path))
    owns = hand_id.owns if hand_id is not None else lambda name: False
    return frozenset(
        model.body(b).name for b in range(1, model.nbody) if owns(model.body(b).name) and model.body_mass[b] > 0
    )


def servo(
    mjcf_path: Any,
    inertia: float | None,
    links: frozenset[str],
    actuated: list[str],
    mass: float | None = None,
    mass_links: frozenset[str] = frozenset(),
) -> Servo:
    """kp, kv and force limit of the MJCF's position actuators, kv as MuJoCo resolves dampratio."""
    model = _spec(mjcf_path, inertia, links, mass, mass_links).compile()
    order = [model.actuator(i).name for i in range(model.nu)]
    joints = [model.joint(int(model.actuator_trnid[i, 0])).name for i in range(model.nu)]
    if joints != actuated:
        raise experiment.SetupError(f"actuator order {order} does not match the actuated joints")
    kp = model.actuator_gainprm[:, 0].copy()
    kv = -model.actuator_biasprm[:, 2].copy()
    limit = np.where(model.actuator_forcelimited, model.actuator_forcerange[:, 1], np.inf)
    return Servo(kp, kv, limit)


class MujocoEngine(Engine):
    name = "mujoco"
    module = "mujoco"
    install = "pip install mujoco"

    def load(self, config: RunConfig) -> None:
        import mujoco

        from svhdesc.model import get

        setup = config.setup
        spec = _spec(get(config.variant).mjcf_path, config.inertia, config.finger_links, config.mass, config.mass_links)
        experiment.add_surface(spec, setup.surface)
        spec.option.timestep = config.timestep
        self.model = spec.compile()
        self.data = mujoco.MjData(self.model)
        model = self.model
        self.box = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, experiment.SURFACE)
        self.tip = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, setup.fingertip)
        self.tip_geoms = {int(g) for g in range(model.ngeom) if model.geom_bodyid[g] == self.tip}
        self.addresses = np.array([model.joint(name).qposadr[0] for name in setup.joints])
        self.actuator_order = np.array(
            [setup.actuated.index(model.joint(int(model.actuator_trnid[i, 0])).name) for i in range(model.nu)]
        )
        home = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_KEY, "home")
        mujoco.mj_resetDataKeyframe(model, self.data, home)
        self._wrench = np.zeros(6)

    def step(self, targets: np.ndarray) -> None:
        import mujoco

        self.data.ctrl[:] = targets[self.actuator_order]
        mujoco.mj_step(self.model, self.data)

    def joint_positions(self) -> np.ndarray:
        return self.data.qpos[self.addresses].copy()

    def fingertip_force(self) -> float:
        import mujoco

        total = 0.0
        for index, contact in enumerate(self.data.contact[: self.data.ncon]):
            if (contact.geom1 == self.box and contact.geom2 in self.tip_geoms) or (
                contact.geom2 == self.box and contact.geom1 in self.tip_geoms
            ):
                mujoco.mj_contactForce(self.model, self.data, index, self._wrench)
                total += self._wrench[0]
        return float(total)

    def fingertip_force_vector(self) -> np.ndarray:
        import mujoco

        total = np.zeros(3)
        for index, contact in enumerate(self.data.contact[: self.data.ncon]):
            pair = (contact.geom1, contact.geom2)
            if self.box in pair and (pair[0] in self.tip_geoms or pair[1] in self.tip_geoms):
                mujoco.mj_contactForce(self.model, self.data, index, self._wrench)
                # The contact frame's rows are its axes; the force acts from geom1 on geom2.
                force = contact.frame.reshape(3, 3).T @ self._wrench[:3]
                total += force if contact.geom1 == self.box else -force
        return total

    def fingertip_position(self) -> np.ndarray:
        return self.data.xpos[self.tip].copy()

    @property
    def timestep(self) -> float:
        return float(self.model.opt.timestep)

    def settings(self) -> dict[str, Any]:
        import mujoco

        opt = self.model.opt
        return {
            "version": self.version(),
            "timestep": float(opt.timestep),
            "integrator": mujoco.mjtIntegrator(opt.integrator).name.removeprefix("mjINT_").lower(),
            "solver": mujoco.mjtSolver(opt.solver).name.removeprefix("mjSOL_").lower(),
            "iterations": int(opt.iterations),
            "tolerance": float(opt.tolerance),
            "cone": mujoco.mjtCone(opt.cone).name.removeprefix("mjCONE_").lower(),
            "impratio": float(opt.impratio),
            "noslip_iterations": int(opt.noslip_iterations),
            "couplings": "joint equalities, solref "
            + (" ".join(f"{v:g}" for v in self.model.eq_solref[0]) if self.model.neq else "-"),
            "servo": "position actuators (implicit PD, kp from the model, dampratio 1, forcerange) + the MJCF's "
            "gravity compensation",
            "friction": "per geom, combined by max",
            "armature": "from the MJCF (URDF has none)",
        }
