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
  surface.sdf; ``tests/test_compare.py`` checks them against the installed sdformat spec).
- Servos: gazebo_ros_control's POSITION_PID law, effort = clamp(p e + d de/dt + g) at the URDF effort
  limit (i = 0), with the gains of ``engine.Servo``. The generated ros_controllers.yaml declares no
  ``gazebo_ros_control/pid_gains``; gazebo_ros_control would then set each joint's position outright
  (Joint::SetPosition), so the PID's gains are the model's kp and kv (connector.yaml's p_gain/d_gain at the
  physical setting), the ones DART and Drake get. g is a gravity feedforward that gazebo_ros_control does
  not have: without it the arm (kp 2000 at the shoulder) sags and the fingertip stops 13 mm short of the
  surface, so nothing would be pressed; the other engines' servos compensate gravity too.
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
import math
import sys
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from .engine import Engine, EngineMissing, RunConfig

DIST_PACKAGES = "/usr/lib/python3/dist-packages"  # Debian's python3-pyode, outside the venv
LIBODE = "libode.so.8"
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
# ODE 0.16 include/ode/contact.h; Gazebo's pyramid friction model (ODEPhysics::Collide).
CONTACT_MU2, CONTACT_SOFT_ERP, CONTACT_SOFT_CFM, CONTACT_APPROX1 = 0x001, 0x008, 0x010, 0x7000
MAX_COLLIDE = 250  # contacts asked of dCollide per pair before keeping the deepest max_contacts


class _Surface(ctypes.Structure):
    _fields_ = [("mode", ctypes.c_int)] + [
        (name, ctypes.c_double)
        for name in (
            "mu mu2 rho rho2 rhoN bounce bounce_vel soft_erp soft_cfm motion1 motion2 motionN slip1 slip2".split()
        )
    ]


class _ContactGeom(ctypes.Structure):
    _fields_ = [
        ("pos", ctypes.c_double * 4),
        ("normal", ctypes.c_double * 4),
        ("depth", ctypes.c_double),
        ("g1", ctypes.c_void_p),
        ("g2", ctypes.c_void_p),
        ("side1", ctypes.c_int),
        ("side2", ctypes.c_int),
    ]


class _Contact(ctypes.Structure):
    _fields_ = [("surface", _Surface), ("geom", _ContactGeom), ("fdir1", ctypes.c_double * 4)]


class _Feedback(ctypes.Structure):
    _fields_ = [(name, ctypes.c_double * 4) for name in ("f1", "t1", "f2", "t2")]


def import_ode() -> Any:
    """pyode from Debian's dist-packages (appended, so the venv's own packages keep precedence)."""
    if DIST_PACKAGES not in sys.path:
        sys.path.append(DIST_PACKAGES)
    return importlib.import_module("ode")


def _libode() -> Any:
    lib = ctypes.CDLL(LIBODE)
    void, real, ptr = None, ctypes.c_double, ctypes.c_void_p
    signatures = {
        "dGeomTriMeshDataCreate": ([], ptr),
        "dGeomTriMeshDataBuildDouble": ([ptr, ptr, ctypes.c_int, ctypes.c_int, ptr, ctypes.c_int, ctypes.c_int], void),
        "dGeomTriMeshDataDestroy": ([ptr], void),
        "dCreateTriMesh": ([ptr, ptr, ptr, ptr, ptr], ptr),
        "dHashSpaceCreate": ([ptr], ptr),
        "dSpaceDestroy": ([ptr], void),
        "dSpaceSetCleanup": ([ptr, ctypes.c_int], void),
        "dGeomSetBody": ([ptr, ptr], void),
        "dGeomGetBody": ([ptr], ptr),
        "dGeomSetOffsetPosition": ([ptr, real, real, real], void),
        "dGeomSetOffsetRotation": ([ptr, ctypes.c_double * 12], void),
        "dBodyGetWorld": ([ptr], ptr),
        "dCollide": ([ptr, ptr, ctypes.c_int, ptr, ctypes.c_int], ctypes.c_int),
        "dSpaceCollide2": ([ptr, ptr, ptr, ptr], void),
        "dJointGroupCreate": ([ctypes.c_int], ptr),
        "dJointGroupEmpty": ([ptr], void),
        "dJointGroupDestroy": ([ptr], void),
        "dJointCreateContact": ([ptr, ptr, ctypes.POINTER(_Contact)], ptr),
        "dJointAttach": ([ptr, ptr, ptr], void),
        "dJointSetFeedback": ([ptr, ctypes.POINTER(_Feedback)], void),
        "dWorldSetQuickStepW": ([ptr, real], void),
        "dWorldGetQuickStepW": ([ptr], real),
    }
    for name, (args, result) in signatures.items():
        function = getattr(lib, name)
        function.argtypes, function.restype = args, result
    return lib


# --- the URDF as sdformat reads it ------------------------------------------------------------------------


def _origin(element: Any) -> np.ndarray:
    transform = np.eye(4)
    origin = element.find("origin") if element is not None else None
    if origin is None:
        return transform
    xyz = [float(v) for v in origin.get("xyz", "0 0 0").split()]
    roll, pitch, yaw = (float(v) for v in origin.get("rpy", "0 0 0").split())
    transform[:3, :3] = _rotz(yaw) @ _roty(pitch) @ _rotx(roll)
    transform[:3, 3] = xyz
    return transform


def _rotx(a: float) -> np.ndarray:
    c, s = math.cos(a), math.sin(a)
    return np.array([[1, 0, 0], [0, c, -s], [0, s, c]])


def _roty(a: float) -> np.ndarray:
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]])


def _rotz(a: float) -> np.ndarray:
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])


def _axis_rotation(axis: np.ndarray, angle: float) -> np.ndarray:
    x, y, z = axis
    c, s, t = math.cos(angle), math.sin(angle), 1 - math.cos(angle)
    return np.array(
        [
            [t * x * x + c, t * x * y - s * z, t * x * z + s * y],
            [t * x * y + s * z, t * y * y + c, t * y * z - s * x],
            [t * x * z - s * y, t * y * z + s * x, t * z * z + c],
        ]
    )


@dataclass
class _Link:
    name: str
    mass: float = 0.0
    com: np.ndarray = field(default_factory=lambda: np.zeros(3))  # in the link frame
    inertia: np.ndarray = field(default_factory=lambda: np.zeros((3, 3)))  # about the com, link axes
    meshes: list[tuple[Path, np.ndarray]] = field(default_factory=list)  # collision OBJ, link-frame pose
    mu: float = GAZEBO_ODE["mu"]


@dataclass
class _Joint:
    name: str
    kind: str
    parent: str
    child: str
    origin: np.ndarray
    axis: np.ndarray
    lower: float
    upper: float
    effort: float
    damping: float


@dataclass
class _Mimic:
    follower: str
    leader: str
    multiplier: float
    offset: float
    max_effort: float


def _read_urdf(text: str) -> tuple[dict[str, _Link], list[_Joint], list[_Mimic]]:
    from lxml import etree

    root = etree.fromstring(text.encode())
    links: dict[str, _Link] = {}
    for element in root.findall("link"):
        link = _Link(element.get("name"))
        inertial = element.find("inertial")
        if inertial is not None:
            frame = _origin(inertial)
            link.mass = float(inertial.find("mass").get("value"))
            values = inertial.find("inertia")
            get = {k: float(values.get(k, "0")) for k in ("ixx", "ixy", "ixz", "iyy", "iyz", "izz")}
            local = np.array(
                [
                    [get["ixx"], get["ixy"], get["ixz"]],
                    [get["ixy"], get["iyy"], get["iyz"]],
                    [get["ixz"], get["iyz"], get["izz"]],
                ]
            )
            link.com = frame[:3, 3].copy()
            link.inertia = frame[:3, :3] @ local @ frame[:3, :3].T
        for collision in element.findall("collision"):
            mesh = collision.find("geometry/mesh")
            if mesh is not None:
                link.meshes.append((Path(mesh.get("filename")), _origin(collision)))
        links[link.name] = link
    for gazebo in root.findall("gazebo"):
        mu = gazebo.find("mu1")
        if gazebo.get("reference") in links and mu is not None:
            links[gazebo.get("reference")].mu = float(mu.text)
    joints = []
    for element in root.findall("joint"):
        limit = element.find("limit")
        dynamics = element.find("dynamics")
        axis = element.find("axis")
        joints.append(
            _Joint(
                element.get("name"),
                element.get("type"),
                element.find("parent").get("link"),
                element.find("child").get("link"),
                _origin(element),
                np.array([float(v) for v in axis.get("xyz").split()]) if axis is not None else np.array([1.0, 0, 0]),
                float(limit.get("lower", "0")) if limit is not None else -math.inf,
                float(limit.get("upper", "0")) if limit is not None else math.inf,
                float(limit.get("effort", "inf")) if limit is not None else math.inf,
                float(dynamics.get("damping", "0")) if dynamics is not None else 0.0,
            )
        )
    mimics = []
    for plugin in root.iter("plugin"):
        if "mimic_joint_plugin" not in plugin.get("filename", ""):
            continue

        def text(tag: str, default: str, plugin: Any = plugin) -> str:
            node = plugin.find(tag)
            return node.text if node is not None else default

        if plugin.find("hasPID") is not None:
            raise ValueError(f"mimic plugin {plugin.get('name')} has hasPID: its PID mode is not modelled")
        mimics.append(
            _Mimic(
                text("mimicJoint", ""),
                text("joint", ""),
                float(text("multiplier", "1")),
                float(text("offset", "0")),
                float(text("maxEffort", "nan")),
            )
        )
    return links, joints, mimics


def _load_obj(path: Path) -> tuple[np.ndarray, np.ndarray]:
    import trimesh

    mesh = trimesh.load(str(path), force="mesh", process=False)
    return np.ascontiguousarray(mesh.vertices, dtype=np.float64), np.ascontiguousarray(mesh.faces, dtype=np.int32)


def _matrix3(rotation: np.ndarray) -> Any:
    """An ODE dMatrix3 (3 rows of 4)."""
    values = np.zeros((3, 4))
    values[:, :3] = rotation
    return (ctypes.c_double * 12)(*values.flatten())


class OdeEngine(Engine):
    name = "ode"
    module = "ode"
    install = "apt-get install python3-pyode"
    distribution = "Py3ODE"

    @classmethod
    def require(cls) -> None:
        try:
            import_ode()
            ctypes.CDLL(LIBODE)
        except (ImportError, OSError):
            raise EngineMissing(f"not installed ({cls.install})") from None

    def load(self, config: RunConfig) -> None:
        import svhdesc

        ode = self.ode = import_ode()
        self.lib = lib = _libode()
        setup = config.setup
        self._dt = config.timestep
        links, joints, mimics = _read_urdf(svhdesc.get(config.variant).urdf_text("path"))
        for name, link in links.items():
            if config.mass is not None and name in config.mass_links and link.mass > 0:
                link.mass = config.mass
            if config.inertia is not None and name in config.finger_links:
                link.inertia = np.eye(3) * config.inertia
        home = dict(zip(setup.joints, setup.home_qpos, strict=True))

        # Link poses at home, and the lumps (movable bodies) fixed joints make.
        children: dict[str, list[_Joint]] = {}
        for joint in joints:
            children.setdefault(joint.parent, []).append(joint)
        roots = set(links) - {j.child for j in joints}
        if len(roots) != 1:
            raise ValueError(f"the URDF has {len(roots)} root links")
        root = roots.pop()
        pose, lump = {root: np.eye(4)}, {root: root}
        order, stack = [], [root]
        while stack:
            parent = stack.pop()
            for joint in children.get(parent, []):
                motion = np.eye(4)
                if joint.kind in ("revolute", "continuous"):
                    motion[:3, :3] = _axis_rotation(joint.axis / np.linalg.norm(joint.axis), home.get(joint.name, 0.0))
                elif joint.kind != "fixed":
                    raise ValueError(f"joint {joint.name}: type {joint.kind} is not modelled")
                pose[joint.child] = pose[parent] @ joint.origin @ motion
                lump[joint.child] = lump[parent] if joint.kind == "fixed" else joint.child
                order.append(joint)
                stack.append(joint.child)

        self.world = world = ode.World()
        world.setGravity(GRAVITY)
        world.setERP(GAZEBO_ODE["erp"])
        world.setCFM(GAZEBO_ODE["cfm"])
        world.setQuickStepNumIterations(GAZEBO_ODE["iters"])
        world.setContactMaxCorrectingVel(GAZEBO_ODE["contact_max_correcting_vel"])
        world.setContactSurfaceLayer(GAZEBO_ODE["contact_surface_layer"])
        self.space = lib.dHashSpaceCreate(None)
        self._probes: list[Any] = []  # pyode geoms that only lend their body's dBodyID
        self.bodies: dict[str, Any] = {}
        self.body_ids: dict[str, int] = {}
        self._meshes: list[tuple[Any, Any, Any, Any]] = []
        self.geom_lump: dict[int, str] = {}
        for name in dict.fromkeys(lump[n] for n in pose):
            members = [n for n in pose if lump[n] == name]
            if name == lump[root]:
                body = None
                com = np.zeros(3)
            else:
                mass = sum(links[n].mass for n in members)
                if mass <= 0:
                    raise ValueError(f"link {name} (with its fixed children) has no mass")
                com = sum(links[n].mass * (pose[n][:3, :3] @ links[n].com + pose[n][:3, 3]) for n in members) / mass
                inertia = np.zeros((3, 3))
                for n in members:
                    rotation = pose[n][:3, :3]
                    offset = rotation @ links[n].com + pose[n][:3, 3] - com
                    inertia += rotation @ links[n].inertia @ rotation.T
                    inertia += links[n].mass * (offset @ offset * np.eye(3) - np.outer(offset, offset))
                frame = pose[name][:3, :3]
                local = frame.T @ inertia @ frame
                body = ode.Body(world)
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
            body_id = self.body_ids.get(name)
            if body_id is None:
                continue  # the fixed base: static, and never near the surface
            for member in members:
                for path, local_pose in links[member].meshes:
                    world_pose = pose[member] @ local_pose
                    self._add_mesh(path, world_pose, body_id, pose[name], com, name)
        self.world_id = lib.dBodyGetWorld(next(iter(self.body_ids.values())))
        lib.dWorldSetQuickStepW(self.world_id, GAZEBO_ODE["sor"])
        self.link_lump = lump

        # Hinges, each at zero angle at home; q = home + sign * angle.
        self.hinges: dict[str, Any] = {}
        self.joint_info: dict[str, _Joint] = {}
        self.subtree: dict[str, list[str]] = {}
        for joint in order:
            if joint.kind == "fixed":
                continue
            hinge = ode.HingeJoint(world)
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
        self.home = home
        for name, joint in self.joint_info.items():
            if joint.kind != "revolute":
                continue
            # ODE's stops are in its own angle: zero at home, signed by ``sign``.
            q0, hinge = home.get(name, 0.0), self.hinges[name]
            low, high = sorted(self.sign[name] * (limit - q0) for limit in (joint.lower, joint.upper))
            hinge.setParam(ode.ParamLoStop, low)
            hinge.setParam(ode.ParamHiStop, high)
            hinge.setParam(ode.ParamStopERP, GAZEBO_ODE["limit_erp"])
            hinge.setParam(ode.ParamStopCFM, GAZEBO_ODE["limit_cfm"])

        self.mimics = [m for m in mimics if m.follower in self.hinges and m.leader in self.hinges]
        for mimic in self.mimics:
            hinge = self.hinges[mimic.follower]
            hinge.setParam(ode.ParamVel, 0.0)
            hinge.setParam(ode.ParamFMax, mimic.max_effort)
        self.names = list(setup.joints)
        self.actuated = list(setup.actuated)
        self.kp, self.kd, self.limit = config.servo.kp, config.servo.kv, config.servo.limit
        self.previous_error: np.ndarray | None = None
        # Gravity feedforward per actuated joint: the weight of every body below it, as a rigid subtree.
        self.lumps = list(self.bodies)
        self.masses = np.array([self.bodies[n].getMass().mass for n in self.lumps])
        self.below = np.array(
            [[lump in self.subtree[name] for lump in self.lumps] for name in self.actuated], dtype=float
        )

        # The surface: a static box (no body), Gazebo's default surface (mu 1).
        surface = setup.surface
        self.box = ode.GeomBox(None, tuple(2.0 * np.asarray(surface.half_size)))
        self.box.setPosition(tuple(surface.position))
        self.box.setRotation(tuple(np.asarray(surface.rotation).flatten()))
        self.box_id = self.box._id()
        self.tip_lump = lump[setup.fingertip]
        tip_body = self.bodies[self.tip_lump]
        tip_rotation = np.array(tip_body.getRotation()).reshape(3, 3)
        self._tip_offset = tip_rotation.T @ (pose[setup.fingertip][:3, 3] - np.array(tip_body.getPosition()))
        self.tip_mu = min(links[setup.fingertip].mu, GAZEBO_ODE["mu"])
        self.contacts = lib.dJointGroupCreate(0)
        self._buffer = (_ContactGeom * MAX_COLLIDE)()
        self._feedback: list[tuple[_Feedback, np.ndarray, bool]] = []
        self._pairs: list[int] = []
        self._near = ctypes.CFUNCTYPE(None, ctypes.c_void_p, ctypes.c_void_p, ctypes.c_void_p)(self._collect)
        kp, kd, dt = 1.0 / (2.0 / GAZEBO_ODE["kp"]), 2.0 * GAZEBO_ODE["kd"], self._dt
        # ODEPhysics::Collide: the two surfaces' kp in series and kd summed, as a spring-damper ERP/CFM.
        self.soft_erp, self.soft_cfm = dt * kp / (dt * kp + kd), 1.0 / (dt * kp + kd)

    def _add_mesh(
        self, path: Path, world_pose: np.ndarray, body_id: int, frame: np.ndarray, com: np.ndarray, lump: str
    ) -> None:
        lib = self.lib
        vertices, faces = _load_obj(path)
        data = lib.dGeomTriMeshDataCreate()
        lib.dGeomTriMeshDataBuildDouble(
            data, vertices.ctypes.data, 3 * 8, len(vertices), faces.ctypes.data, faces.size, 3 * 4
        )
        geom = lib.dCreateTriMesh(self.space, data, None, None, None)
        self._meshes.append((data, geom, vertices, faces))  # ODE keeps pointers into the arrays
        lib.dGeomSetBody(geom, body_id)
        rotation = frame[:3, :3]
        lib.dGeomSetOffsetPosition(geom, *(rotation.T @ (world_pose[:3, 3] - com)))
        lib.dGeomSetOffsetRotation(geom, _matrix3(rotation.T @ world_pose[:3, :3]))
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
        rotation = _axis_rotation(np.array(hinge.getAxis()), delta)
        for lump in self.subtree[name]:
            body = self.bodies[lump]
            position = np.array(body.getPosition())
            body.setPosition(tuple(anchor + rotation @ (position - anchor)))
            body.setRotation(tuple((rotation @ np.array(body.getRotation()).reshape(3, 3)).flatten()))

    def _position(self, name: str) -> float:
        return self.home.get(name, 0.0) + self.sign[name] * self.hinges[name].getAngle()

    def _gravity(self) -> np.ndarray:
        """Joint torques that hold the subtrees' weight: -axis . sum m_b (p_b - anchor) x g."""
        centres = np.array([self.bodies[n].getPosition() for n in self.lumps])
        anchors = np.array([self.hinges[n].getAnchor() for n in self.actuated])
        axes = np.array([self.hinges[n].getAxis() for n in self.actuated])
        moments = self.below @ (self.masses[:, None] * centres) - (self.below @ self.masses)[:, None] * anchors
        return -np.einsum("ij,ij->i", axes, np.cross(moments, np.asarray(GRAVITY)))

    def _collect(self, _data: Any, first: Any, second: Any) -> None:
        self._pairs.append(second if first == self.box_id else first)

    def step(self, targets: np.ndarray) -> None:
        lib = self.lib
        # Mimic plugins (WorldUpdateBegin): followers set from their leaders.
        for mimic in self.mimics:
            angle = self._position(mimic.leader) * mimic.multiplier + mimic.offset
            self._rotate(mimic.follower, angle - self._position(mimic.follower))
        # gazebo_ros_control writeSim, POSITION_PID: a PID on the position error (control_toolbox::Pid,
        # derivative of the error over the period), clamped to the effort limit, as a joint force.
        positions = np.array([self._position(name) for name in self.actuated])
        error = targets - positions
        derivative = np.zeros_like(error) if self.previous_error is None else (error - self.previous_error) / self._dt
        self.previous_error = error
        effort = np.clip(self.kp * error + self.kd * derivative + self._gravity(), -self.limit, self.limit)
        for name, torque in zip(self.actuated, effort, strict=True):
            self.hinges[name].addTorque(self.sign[name] * float(torque))
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
            count = lib.dCollide(self.box_id, geom, MAX_COLLIDE, self._buffer, ctypes.sizeof(_ContactGeom))
            found = sorted(self._buffer[:count], key=lambda c: -c.depth)[: GAZEBO_ODE["max_contacts"]]
            lump = self.geom_lump[geom]
            body = self.body_ids.get(lump)
            if body is None:
                continue
            tip = lump == self.tip_lump
            for contact_geom in found:
                contact = _Contact()
                contact.geom = contact_geom
                contact.surface.mode = CONTACT_MU2 | CONTACT_SOFT_ERP | CONTACT_SOFT_CFM | CONTACT_APPROX1
                contact.surface.mu = contact.surface.mu2 = self.tip_mu if tip else GAZEBO_ODE["mu"]
                contact.surface.soft_erp, contact.surface.soft_cfm = self.soft_erp, self.soft_cfm
                joint = lib.dJointCreateContact(self.world_id, self.contacts, ctypes.byref(contact))
                # The box has no body; ODE then makes the robot's body its body 1 (feedback f1).
                lib.dJointAttach(joint, None, body)
                if tip:
                    feedback = _Feedback()
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
            "servo": "gazebo_ros_control POSITION_PID (p, d from the model, i 0), effort limits, plus a gravity "
            "feedforward (gazebo_ros_control has none)",
            "friction": f"pyramid (Approx1), min of the two mu (fingertip {self.tip_mu:g}, surface 1)",
            "damping": "URDF joint damping, explicit",
            "armature": "none (URDF)",
        }

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
