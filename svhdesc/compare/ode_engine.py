"""ODE (Debian's libode8 through python3-pyode): the URDF as Gazebo Classic runs it, plus the surface.

Gazebo Classic, the engine of thesis Table 5.1, runs ODE. This adapter rebuilds that world:

- Bodies from the URDF's inertials. Links on fixed joints are lumped into their parent, as sdformat's
  URDF parser does; a link's inertia setting is applied before lumping.
- Hinge joints with the URDF's limits (stop ERP 0.2, CFM 0: sdformat's joint defaults) and the URDF's
  damping, applied explicitly as Gazebo does without ``implicit_spring_damper`` (sdformat default false).
- Collision: every OBJ hull of the URDF as an ODE trimesh (OPCODE) against the surface box. Gazebo's
  ``self_collide`` defaults to false, so no robot link collides with another (the other engines exclude
  the pairs the MJCF excludes; with the surface as the only other body, only robot-surface pairs matter).
- Solver: quickstep at 1 ms with Gazebo's ODE defaults (``GAZEBO_ODE``, read from sdformat's physics.sdf and
  surface.sdf; ``tests/compare/test_compare.py`` checks them against the installed sdformat spec).
- Servos: gazebo_ros_control's DefaultRobotHWSim as the generated files configure it. The URDF's
  transmissions declare ``PositionJointInterface``; each command is first saturated by joint_limits_interface
  (PositionJointSaturationHandle: the URDF's position limits, and at most velocity x period from the previous
  command). The generated ros_controllers.yaml declares no ``gazebo_ros_control/pid_gains``, so writeSim runs
  POSITION: Joint::SetPosition(0, command, preserveWorldVelocity=true) before every step, with the joint's
  motor holding zero velocity up to the URDF effort (initSim's SetParam("fmax")). A joint that has pid_gains
  there runs POSITION_PID: effort = clamp(p e + i-term + d de/dt) at the URDF effort, as a joint force, and no
  gravity compensation. ``OdePid`` runs POSITION_PID with the comparison's kp and kv (connector.yaml's
  p_gain/d_gain at the physical setting) for every servo, and ``OdeWithFeedforward`` adds to it the gravity
  feedforward the other engines' servos have (both run by benchmarks/compare_bench.py).
- Couplings: the URDF's roboticsgroup mimic-joint plugins without ``hasPID``: before every step the
  follower is set to multiplier * leader + offset by Joint::SetPosition(0, angle, preserveWorldVelocity=true)
  (the follower's subtree is rotated about the joint, world velocities kept), and its joint motor holds
  zero velocity up to ``maxEffort`` (the plugin's SetParam("fmax")).

Debian's pyode is built without trimesh support, so the trimesh geoms, the collision call and the contact
joints go through ctypes to the same libode.so.8 that pyode links (ODE 0.16, double precision).
"""

from __future__ import annotations

import ctypes
import importlib
import sys
from pathlib import Path
from typing import Any

import numpy as np

from svhdesc.compare import libode
from svhdesc.compare.engine import Engine, EngineMissing, RunConfig
from svhdesc.compare.urdf_tree import Joint, Link, axis_rotation, load_obj, lumped_inertial, read_urdf, tree

DIST_PACKAGES = "/usr/lib/python3/dist-packages"  # Debian's python3-pyode, outside the venv
# Gazebo Classic's ODE defaults, as sdformat 1.6 declares them (physics.sdf: <max_contacts>, <ode><solver>,
# <ode><constraints>; surface.sdf: <contact><ode> kp, kd, <friction><ode> mu) and joint.sdf's limit
# cfm/erp. ODE's own SOR default (dxQuickStepParameters w) is Gazebo's 1.3; pyode cannot set it.
GAZEBO_ODE = {
    "max_step_size": 0.001,
    "iters": 50,
    "sor": 1.3,
    "cfm": 0.0,
    "erp": 0.2,
    "contact_max_correcting_vel": 100.0,
    "contact_surface_layer": 0.001,
    "max_contacts": 20,
    "kp": 1e12,
    "kd": 1.0,
    "mu": 1.0,
    "limit_cfm": 0.0,
    "limit_erp": 0.2,
}
GRAVITY = (0.0, 0.0, -9.81)
POSITION, POSITION_PID = "POSITION", "POSITION_PID"  # DefaultRobotHWSim's control methods
MAX_COLLIDE = 250  # contacts asked of dCollide per pair before keeping the deepest max_contacts


def pid_gains(variant: str) -> dict[str, dict[str, float]]:
    """``gazebo_ros_control/pid_gains/<joint>`` (p, i, d, i_clamp) of the variant's generated ros_controllers.yaml."""
    from svhdesc.model import get

    return read_pid_gains(get(variant).directory / "config" / "ros_controllers.yaml")


def read_pid_gains(path: Path) -> dict[str, dict[str, float]]:
    """What gazebo_ros_control's initSim finds under ``gazebo_ros_control/pid_gains`` in a controllers file."""
    import yaml

    document = yaml.safe_load(path.read_text()) if path.is_file() else None
    gains = ((document or {}).get("gazebo_ros_control") or {}).get("pid_gains") or {}
    keys = ("p", "i", "d", "i_clamp")
    return {name: {k: float(values.get(k, 0.0)) for k in keys} for name, values in gains.items()}


def import_ode() -> Any:
    """pyode from Debian's dist-packages (appended, so the venv's own packages keep precedence)."""
    if DIST_PACKAGES not in sys.path:
        sys.path.append(DIST_PACKAGES)
    return importlib.import_module("ode")


class OdeEngine(Engine):
    name = "ode"
    module = "ode"
    install = "apt-get install python3-pyode"
    distribution = "Py3ODE"
    gravity_feedforward = False  # gazebo_ros_control has none
    comparison_pid = False  # True: POSITION_PID with the comparison's kp/kv for every servo (OdePid)

    @classmethod
    def require(cls) -> None:
        try:
            import_ode()
            ctypes.CDLL(libode.LIBODE)
        except (ImportError, OSError):
            raise EngineMissing(f"not installed ({cls.install})") from None

    def load(self, config: RunConfig) -> None:
        from svhdesc.model import get

        self.ode = import_ode()
        self.lib = libode.load()
        setup = config.setup
        self._dt = config.timestep
        links, joints, mimics = read_urdf(get(config.variant).urdf_text("path"))
        for name, link in links.items():
            if config.mass is not None and name in config.mass_links and link.mass > 0:
                link.mass = config.mass
            if config.inertia is not None and name in config.finger_links:
                link.inertia = np.eye(3) * config.inertia
        self.home = dict(zip(setup.joints, setup.home_qpos, strict=True))
        pose, lump, order, root = tree(links, joints, self.home)
        self._make_world()
        self._make_bodies(links, pose, lump, root)
        self._make_hinges(order, pose, lump)
        self.mimics = [m for m in mimics if m.follower in self.hinges and m.leader in self.hinges]
        for mimic in self.mimics:  # the plugin's SetParam("fmax"): a motor holding zero velocity
            hinge = self.hinges[mimic.follower]
            hinge.setParam(self.ode.ParamVel, 0.0)
            hinge.setParam(self.ode.ParamFMax, mimic.max_effort)
        self.names = list(setup.joints)
        self.actuated = list(setup.actuated)
        self._make_servos(config)
        # Gravity feedforward per actuated joint: the weight of every body below it, as a rigid subtree.
        self.lumps = list(self.bodies)
        self.masses = np.array([self.bodies[n].getMass().mass for n in self.lumps])
        self.below = np.array(
            [[lump in self.subtree[name] for lump in self.lumps] for name in self.actuated], dtype=float
        )
        self._make_surface(setup, links, pose, lump)

    def _make_servos(self, config: RunConfig) -> None:
        """DefaultRobotHWSim::initSim: POSITION_PID where pid_gains are given, else POSITION with fmax."""
        count = len(self.actuated)
        if self.comparison_pid:
            pairs = zip(self.actuated, config.servo.kp, config.servo.kv, strict=True)
            gains = {n: {"p": p, "i": 0.0, "d": d, "i_clamp": 0.0} for n, p, d in pairs}
        else:
            gains = pid_gains(config.variant)
        self.modes = [POSITION_PID if name in gains else POSITION for name in self.actuated]
        self.kp = np.array([gains.get(n, {}).get("p", 0.0) for n in self.actuated])
        self.ki = np.array([gains.get(n, {}).get("i", 0.0) for n in self.actuated])
        self.kd = np.array([gains.get(n, {}).get("d", 0.0) for n in self.actuated])
        self.i_clamp = np.array([gains.get(n, {}).get("i_clamp", 0.0) for n in self.actuated])
        joints = [self.joint_info[n] for n in self.actuated]
        self.limit = np.array([j.effort for j in joints])  # registerJointLimits: the URDF's effort
        self.lower = np.array([j.lower if j.kind == "revolute" else -np.inf for j in joints])
        self.upper = np.array([j.upper if j.kind == "revolute" else np.inf for j in joints])
        self.max_velocity = np.array([j.velocity for j in joints])
        self.integral, self.previous_error = np.zeros(count), np.zeros(count)
        self.previous_command: np.ndarray | None = None
        for name, mode, effort in zip(self.actuated, self.modes, self.limit, strict=True):
            if mode == POSITION:  # SetParam("fmax", 0, effort limit): a motor holding zero velocity
                self.hinges[name].setParam(self.ode.ParamVel, 0.0)
                self.hinges[name].setParam(self.ode.ParamFMax, float(effort))

    def _saturate(self, targets: np.ndarray) -> np.ndarray:
        """joint_limits_interface's PositionJointSaturationHandle on every position command."""
        previous = self.previous_command
        if previous is None:
            previous = np.array([self._position(name) for name in self.actuated])
        reach = self.max_velocity * self._dt
        low, high = np.maximum(previous - reach, self.lower), np.minimum(previous + reach, self.upper)
        self.previous_command = np.clip(targets, low, high)
        return self.previous_command

    def _write(self, commands: np.ndarray) -> None:
        """DefaultRobotHWSim::writeSim: SetPosition for POSITION joints, a clamped PID force for POSITION_PID."""
        positions = np.array([self._position(name) for name in self.actuated])
        error = commands - positions
        # control_toolbox::Pid::computeCommand: d from the error's change over the period (the last error
        # starts at 0), the integral term clamped to +-i_clamp.
        derivative = (error - self.previous_error) / self._dt
        self.previous_error = error
        self.integral += error * self._dt
        integral = np.clip(self.ki * self.integral, -self.i_clamp, self.i_clamp)
        pid = self.kp * error + integral + self.kd * derivative + self._gravity()
        effort = np.clip(pid, -self.limit, self.limit)
        for index, name in enumerate(self.actuated):
            if self.modes[index] == POSITION:
                self._rotate(name, float(error[index]))
            else:
                self.hinges[name].addTorque(self.sign[name] * float(effort[index]))

    def _make_world(self) -> None:
        ode, lib = self.ode, self.lib
        # quickstep reorders its constraints at random from ODE's one global seed: reset it, so a run does not
        # depend on what ran before it in the process.
        lib.dRandSetSeed(0)
        self.world = world = ode.World()
        world.setGravity(GRAVITY)
        world.setERP(GAZEBO_ODE["erp"])
        world.setCFM(GAZEBO_ODE["cfm"])
        world.setQuickStepNumIterations(GAZEBO_ODE["iters"])
        world.setContactMaxCorrectingVel(GAZEBO_ODE["contact_max_correcting_vel"])
        world.setContactSurfaceLayer(GAZEBO_ODE["contact_surface_layer"])
        self.space = lib.dHashSpaceCreate(None)
        self.contacts = lib.dJointGroupCreate(0)

    def _make_bodies(
        self, links: dict[str, Link], pose: dict[str, np.ndarray], lump: dict[str, str], root: str
    ) -> None:
        """One ODE body per lump at its centre of mass (ODE's body frame), its hulls as trimesh geoms."""
        ode, lib = self.ode, self.lib
        self._probes: list[Any] = []  # pyode geoms that only lend their body's dBodyID
        self.bodies: dict[str, Any] = {}
        self.body_ids: dict[str, int] = {}
        self._meshes: list[tuple[Any, Any, Any, Any]] = []
        self.geom_lump: dict[int, str] = {}
        for name in dict.fromkeys(lump[n] for n in pose):
            if name == lump[root]:
                continue  # the fixed base: static, and never near the surface
            members = [n for n in pose if lump[n] == name]
            mass, com, inertia = lumped_inertial(links, pose, members)
            if mass <= 0:
                raise ValueError(f"link {name} (with its fixed children) has no mass")
            frame = pose[name][:3, :3]
            local = frame.T @ inertia @ frame
            body = ode.Body(self.world)
            parameters = ode.Mass()
            parameters.setParameters(
                mass, 0, 0, 0, local[0, 0], local[1, 1], local[2, 2], local[0, 1], local[0, 2], local[1, 2]
            )
            body.setMass(parameters)
            body.setPosition(tuple(com))
            body.setRotation(tuple(frame.flatten()))
            probe = ode.GeomSphere(None, 0.001)
            probe.setBody(body)
            self._probes.append(probe)
            self.bodies[name] = body
            self.body_ids[name] = lib.dGeomGetBody(probe._id())
            for member in members:
                for path, local_pose in links[member].meshes:
                    self._add_mesh(path, pose[member] @ local_pose, self.body_ids[name], pose[name], com, name)
        self.world_id = lib.dBodyGetWorld(next(iter(self.body_ids.values())))
        lib.dWorldSetQuickStepW(self.world_id, GAZEBO_ODE["sor"])

    def _make_hinges(self, order: list[Joint], pose: dict[str, np.ndarray], lump: dict[str, str]) -> None:
        """Hinges at zero angle at home (q = home + sign * angle), with the URDF's limits in ODE's angle."""
        ode = self.ode
        self.hinges: dict[str, Any] = {}
        self.joint_info: dict[str, Joint] = {}
        self.subtree: dict[str, list[str]] = {}
        for joint in order:
            if joint.kind == "fixed":
                continue
            hinge = ode.HingeJoint(self.world)
            parent = self.bodies.get(lump[joint.parent])
            hinge.attach(parent if parent is not None else ode.environment, self.bodies[joint.child])
            frame = pose[joint.child]
            hinge.setAnchor(tuple(frame[:3, 3]))
            hinge.setAxis(tuple(frame[:3, :3] @ (joint.axis / np.linalg.norm(joint.axis))))
            self.hinges[joint.name] = hinge
            self.joint_info[joint.name] = joint
            below = [joint.child]
            for other in order:  # order is depth first: descendants follow their parent
                if lump[other.parent] in below and other.kind != "fixed":
                    below.append(other.child)
            self.subtree[joint.name] = below
        self.sign = {name: self._calibrate(name) for name in self.hinges}
        for name, joint in self.joint_info.items():
            if joint.kind != "revolute":
                continue
            q0, hinge = self.home.get(name, 0.0), self.hinges[name]
            low, high = sorted(self.sign[name] * (limit - q0) for limit in (joint.lower, joint.upper))
            hinge.setParam(ode.ParamLoStop, low)
            hinge.setParam(ode.ParamHiStop, high)
            hinge.setParam(ode.ParamStopERP, GAZEBO_ODE["limit_erp"])
            hinge.setParam(ode.ParamStopCFM, GAZEBO_ODE["limit_cfm"])

    def _make_surface(
        self, setup: Any, links: dict[str, Link], pose: dict[str, np.ndarray], lump: dict[str, str]
    ) -> None:
        """The surface: a static box (no body) with Gazebo's default surface, and the contact bookkeeping."""
        surface = setup.surface
        self.box = self.ode.GeomBox(None, tuple(2.0 * np.asarray(surface.half_size)))
        self.box.setPosition(tuple(surface.position))
        self.box.setRotation(tuple(np.asarray(surface.rotation).flatten()))
        self.box_id = self.box._id()
        self.tip_lump = lump[setup.fingertip]
        tip_body = self.bodies[self.tip_lump]
        tip_rotation = np.array(tip_body.getRotation()).reshape(3, 3)
        self._tip_offset = tip_rotation.T @ (pose[setup.fingertip][:3, 3] - np.array(tip_body.getPosition()))
        self.tip_mu = min(links[setup.fingertip].mu, GAZEBO_ODE["mu"])
        self._buffer = (libode.ContactGeom * MAX_COLLIDE)()
        self._feedback: list[tuple[libode.Feedback, np.ndarray, bool]] = []
        self._pairs: list[int] = []
        self._near = ctypes.CFUNCTYPE(None, ctypes.c_void_p, ctypes.c_void_p, ctypes.c_void_p)(self._collect)
        kp, kd, dt = 1.0 / (2.0 / GAZEBO_ODE["kp"]), 2.0 * GAZEBO_ODE["kd"], self._dt
        # ODEPhysics::Collide: the two surfaces' kp in series and kd summed, as a spring-damper ERP/CFM.
        self.soft_erp, self.soft_cfm = dt * kp / (dt * kp + kd), 1.0 / (dt * kp + kd)

    def _add_mesh(
        self, path: Path, world_pose: np.ndarray, body_id: int, frame: np.ndarray, com: np.ndarray, lump: str
    ) -> None:
        lib = self.lib
        vertices, faces = load_obj(path)
        data = lib.dGeomTriMeshDataCreate()
        lib.dGeomTriMeshDataBuildDouble(
            data, vertices.ctypes.data, 3 * 8, len(vertices), faces.ctypes.data, faces.size, 3 * 4
        )
        geom = lib.dCreateTriMesh(self.space, data, None, None, None)
        self._meshes.append((data, geom, vertices, faces))  # ODE keeps pointers into the arrays
        lib.dGeomSetBody(geom, body_id)
        rotation = frame[:3, :3]
        lib.dGeomSetOffsetPosition(geom, *(rotation.T @ (world_pose[:3, 3] - com)))
        lib.dGeomSetOffsetRotation(geom, libode.matrix3(rotation.T @ world_pose[:3, :3]))
        self.geom_lump[geom] = lump

    def _calibrate(self, name: str) -> float:
        """ODE's hinge angle sign relative to the URDF's axis (it depends on which body ODE calls body 1)."""
        step = 1e-3
        self._rotate(name, step)
        angle = self.hinges[name].getAngle()
        self._rotate(name, -step)
        return 1.0 if angle > 0 else -1.0

    def _rotate(self, name: str, delta: float) -> None:
        """Joint::SetPosition with preserveWorldVelocity: turn the joint's subtree, keep world velocities."""
        hinge = self.hinges[name]
        anchor = np.array(hinge.getAnchor())
        rotation = axis_rotation(np.array(hinge.getAxis()), delta)
        for lump in self.subtree[name]:
            body = self.bodies[lump]
            position = np.array(body.getPosition())
            body.setPosition(tuple(anchor + rotation @ (position - anchor)))
            body.setRotation(tuple((rotation @ np.array(body.getRotation()).reshape(3, 3)).flatten()))

    def _position(self, name: str) -> float:
        return self.home.get(name, 0.0) + self.sign[name] * self.hinges[name].getAngle()

    def _gravity(self) -> np.ndarray:
        """Joint torques that hold the subtrees' weight: -axis . sum m_b (p_b - anchor) x g."""
        if not self.gravity_feedforward:
            return np.zeros(len(self.actuated))
        centres = np.array([self.bodies[n].getPosition() for n in self.lumps])
        anchors = np.array([self.hinges[n].getAnchor() for n in self.actuated])
        axes = np.array([self.hinges[n].getAxis() for n in self.actuated])
        moments = self.below @ (self.masses[:, None] * centres) - (self.below @ self.masses)[:, None] * anchors
        return -np.einsum("ij,ij->i", axes, np.cross(moments, np.asarray(GRAVITY)))

    def _collect(self, _data: Any, first: Any, second: Any) -> None:
        self._pairs.append(second if first == self.box_id else first)

    def step(self, targets: np.ndarray) -> None:
        lib = self.lib
        # WorldUpdateBegin, in the plugins' order in the URDF: gazebo_ros_control (readSim, the controllers,
        # writeSim), then the mimic plugins, which set each follower from its leader.
        self._write(self._saturate(targets))
        for mimic in self.mimics:
            angle = self._position(mimic.leader) * mimic.multiplier + mimic.offset
            self._rotate(mimic.follower, angle - self._position(mimic.follower))
        # Joint damping, explicit (no implicit_spring_damper).
        for name, joint in self.joint_info.items():
            if joint.damping:
                hinge = self.hinges[name]
                hinge.addTorque(-joint.damping * hinge.getAngleRate())
        # Collide the surface with the robot's hulls, then step.
        self._pairs.clear()
        self._feedback.clear()
        lib.dSpaceCollide2(self.box_id, self.space, None, self._near)
        for geom in self._pairs:
            count = lib.dCollide(self.box_id, geom, MAX_COLLIDE, self._buffer, ctypes.sizeof(libode.ContactGeom))
            found = sorted(self._buffer[:count], key=lambda c: -c.depth)[: GAZEBO_ODE["max_contacts"]]
            lump = self.geom_lump[geom]
            body = self.body_ids.get(lump)
            if body is None:
                continue
            tip = lump == self.tip_lump
            for contact_geom in found:
                contact = libode.Contact()
                contact.geom = contact_geom
                contact.surface.mode = libode.CONTACT_MU2 | libode.CONTACT_SOFT_ERP | libode.CONTACT_SOFT_CFM
                contact.surface.mode |= libode.CONTACT_APPROX1
                contact.surface.mu = contact.surface.mu2 = self.tip_mu if tip else GAZEBO_ODE["mu"]
                contact.surface.soft_erp, contact.surface.soft_cfm = self.soft_erp, self.soft_cfm
                joint = lib.dJointCreateContact(self.world_id, self.contacts, ctypes.byref(contact))
                # The box has no body; ODE then makes the robot's body its body 1 (feedback f1).
                lib.dJointAttach(joint, None, body)
                if tip:
                    feedback = libode.Feedback()
                    lib.dJointSetFeedback(joint, ctypes.byref(feedback))
                    self._feedback.append((feedback, np.array(contact_geom.normal[:3]), True))
        self.world.quickStep(self._dt)
        self._forces = [np.array(f.f1[:3]) for f, _, _ in self._feedback]
        self._normals = [n for _, n, _ in self._feedback]
        lib.dJointGroupEmpty(self.contacts)

    def joint_positions(self) -> np.ndarray:
        return np.array([self._position(name) for name in self.names])

    def fingertip_force(self) -> float:
        forces = getattr(self, "_forces", [])
        return float(sum(abs(float(f @ n)) for f, n in zip(forces, self._normals, strict=True)))

    def fingertip_force_vector(self) -> np.ndarray:
        forces = getattr(self, "_forces", [])
        return np.sum(forces, axis=0) if forces else np.zeros(3)

    def fingertip_position(self) -> np.ndarray:
        body = self.bodies[self.tip_lump]
        rotation = np.array(body.getRotation()).reshape(3, 3)
        return np.array(body.getPosition()) + rotation @ self._tip_offset

    @property
    def timestep(self) -> float:
        return self._dt

    def settings(self) -> dict[str, Any]:
        return {
            "version": f"pyode {self.version()}, libode8 (ODE 0.16, double precision)",
            "timestep": self._dt,
            "solver": f"quickstep, {GAZEBO_ODE['iters']} iterations, SOR "
            f"{self.lib.dWorldGetQuickStepW(self.world_id):g} (Gazebo's ODE defaults)",
            "constraints": f"ERP {self.world.getERP():g}, CFM {self.world.getCFM():g}, "
            f"contact_max_correcting_vel {self.world.getContactMaxCorrectingVel():g}, "
            f"contact_surface_layer {self.world.getContactSurfaceLayer():g}",
            "contacts": f"OBJ hulls as ODE trimeshes vs the box, at most {GAZEBO_ODE['max_contacts']} per pair, soft "
            f"ERP {self.soft_erp:.6g} / CFM {self.soft_cfm:.3g} (surface kp {GAZEBO_ODE['kp']:g}, kd "
            f"{GAZEBO_ODE['kd']:g}); no self-collision (Gazebo's self_collide default)",
            "couplings": "mimic-joint plugin: SetPosition(preserveWorldVelocity) before each step, fmax = maxEffort",
            "servo": self._servo_text(),
            "friction": f"pyramid (Approx1), min of the two mu (fingertip {self.tip_mu:g}, surface 1)",
            "damping": "URDF joint damping, explicit",
            "armature": "none (URDF)",
        }

    def _servo_text(self) -> str:
        commands = "commands saturated at the URDF's position and velocity limits (joint_limits_interface)"
        if POSITION_PID not in self.modes:
            return (
                "gazebo_ros_control POSITION (no pid_gains in the generated ros_controllers.yaml): "
                f"Joint::SetPosition every step, fmax = the URDF effort; {commands}"
            )
        source = "the comparison's kp, kv, i 0" if self.comparison_pid else "pid_gains of ros_controllers.yaml"
        return (
            f"gazebo_ros_control POSITION_PID on {self.modes.count(POSITION_PID)} joints ({source}), clamped at the "
            "URDF effort, "
            + ("plus a gravity feedforward" if self.gravity_feedforward else "no gravity compensation")
            + f"; {commands}"
        )

    def close(self) -> None:
        lib = getattr(self, "lib", None)
        if lib is None:
            return
        if getattr(self, "contacts", None):
            lib.dJointGroupDestroy(self.contacts)
            self.contacts = None
        if getattr(self, "space", None):
            lib.dSpaceDestroy(self.space)  # and its geoms (cleanup mode)
            self.space = None
        for data, *_ in self._meshes:
            lib.dGeomTriMeshDataDestroy(data)
        self._meshes.clear()


class OdePid(OdeEngine):
    """gazebo_ros_control's POSITION_PID on every servo with the comparison's kp and kv (pid_gains set to them)."""

    name = "ode-pid"
    comparison_pid = True


class OdeWithFeedforward(OdePid):
    """That PID plus the gravity feedforward DART's and Drake's servos get (MuJoCo's model has its own)."""

    name = "ode-feedforward"
    gravity_feedforward = True
