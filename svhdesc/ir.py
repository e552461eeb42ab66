"""Neutral intermediate representation: what every processor reads and every exporter renders.

All types are frozen; processors return new objects with ``dataclasses.replace``.
Lengths in metres, angles in radians, masses in kg, inertias in kg m^2 about the centre of mass
in the link frame.
"""

from __future__ import annotations

from dataclasses import dataclass

Vec3 = tuple[float, float, float]


@dataclass(frozen=True)
class Pose:
    xyz: Vec3 = (0.0, 0.0, 0.0)
    rpy: Vec3 = (0.0, 0.0, 0.0)


@dataclass(frozen=True)
class Inertial:
    mass: float
    com: Vec3
    # ixx, ixy, ixz, iyy, iyz, izz in the link frame (axes not rotated).
    inertia: tuple[float, float, float, float, float, float]


@dataclass(frozen=True)
class Geometry:
    """A visual or collision shape. ``kind`` is mesh|box|cylinder|sphere|capsule."""

    kind: str
    origin: Pose = Pose()
    size: tuple[float, ...] = ()
    mesh: str | None = None  # absolute path of the source mesh, or asset name after processing
    scale: Vec3 = (1.0, 1.0, 1.0)
    rgba: tuple[float, float, float, float] | None = None
    material: str | None = None
    name: str | None = None


@dataclass(frozen=True)
class Contact:
    """Surface properties of a link's collision geoms."""

    mu: float
    torsional: float = 0.0
    rolling: float = 0.0
    condim: int = 3


@dataclass(frozen=True)
class Link:
    name: str
    inertial: Inertial | None = None
    visuals: tuple[Geometry, ...] = ()
    collisions: tuple[Geometry, ...] = ()
    contact: Contact | None = None

    @property
    def has_geometry(self) -> bool:
        return bool(self.visuals or self.collisions)


@dataclass(frozen=True)
class Mimic:
    """joint = sum(coeffs[i] * channel_joint**i); URDF carries only the linear part."""

    joint: str
    coeffs: tuple[float, ...]


@dataclass(frozen=True)
class Joint:
    name: str
    type: str  # revolute|continuous|prismatic|fixed
    parent: str
    child: str
    origin: Pose = Pose()
    axis: Vec3 = (1.0, 0.0, 0.0)
    lower: float = 0.0
    upper: float = 0.0
    effort: float = 0.0
    velocity: float = 0.0
    damping: float = 0.0
    friction: float = 0.0
    armature: float = 0.0
    limit_margin: float = 0.0  # MuJoCo: limit active within this distance (no on/off chatter at the limit)
    limit_solref: tuple[float, float] | None = None
    mimic: Mimic | None = None
    source: str = ""  # file:line of the definition, for error messages

    @property
    def movable(self) -> bool:
        return self.type != "fixed"


@dataclass(frozen=True)
class Channel:
    """One motor of the real driver: drives ``joint``; coupled joints follow it."""

    name: str
    joint: str
    lower: float
    upper: float
    effort: float
    velocity: float
    # The driver's fingertip force (N) at the channel's current limit; None where the driver gives none.
    # validate's fingertip_force holds the simulated finger to it.
    tip_force: float | None = None


@dataclass(frozen=True)
class Coupling:
    joint: str
    channel: str  # channel name
    coeffs: tuple[float, ...]  # polynomial in the channel joint's position, constant term first


@dataclass(frozen=True)
class Actuator:
    """A servo on a joint (hand channel or arm joint): a position servo, or a continuous joint's velocity servo
    (``kind`` velocity: ``lower``/``upper`` its commanded velocity range, ``kp`` its velocity gain kv)."""

    name: str
    joint: str
    lower: float
    upper: float
    effort: float
    kp: float
    dampratio: float = 1.0
    limited: bool = True  # False: a position servo without limits (a continuous joint), ctrl not clamped
    kind: str = "position"  # or "velocity" (joints.NAME.servo)

    @property
    def velocity(self) -> bool:
        return self.kind == "velocity"


@dataclass(frozen=True)
class Transmission:
    name: str
    joint: str
    interface: str
    reduction: float = 1.0


@dataclass(frozen=True)
class Keyframe:
    name: str
    qpos: tuple[tuple[str, float], ...]  # every movable joint, spec-propagated: the pose
    # The servo targets (joint -> target) where they differ from the pose: a grasp's, closed past its object (the
    # pose stops where the fingers meet: compiler/probes/keyframe_contacts.py). None: the pose is the target.
    targets: tuple[tuple[str, float], ...] | None = None

    def servo_targets(self) -> dict[str, float]:
        """Each joint's servo target: ``targets`` where given, else the pose."""
        return dict(self.qpos if self.targets is None else self.targets)


@dataclass(frozen=True)
class ForceSensor:
    name: str
    link: str
    site_pos: Vec3 = (0.0, 0.0, 0.0)
    site_size: float = 0.008


@dataclass(frozen=True)
class Physics:
    """World options only the MJCF can carry: solver step, couplings' stiffness, gravity compensation."""

    timestep: float = 0.002
    noslip_iterations: int = 0
    coupling_solref: tuple[float, ...] = (0.002, 1.0)
    coupling_solimp: tuple[float, ...] = (0.99, 0.999, 0.0001, 0.5, 2.0)
    gravity_compensation: bool = True
    cone: str = "elliptic"


@dataclass(frozen=True)
class Ground:
    """Where scene.xml puts the floor; an arm stands on a pedestal of this radius when the floor is lower."""

    floor_z: float = 0.0
    pedestal_radius: float = 0.0


@dataclass(frozen=True)
class HandId:
    """Which hand a robot carries: its names' prefix (``<prefix>_<part>``; None: parts keep their own names) and its
    side (right, left; None where the config does not say). From the config, resolved once by the pipeline."""

    prefix: str | None = None
    side: str | None = None


@dataclass(frozen=True)
class Robot:
    name: str
    links: tuple[Link, ...]
    joints: tuple[Joint, ...]
    root: str
    channels: tuple[Channel, ...] = ()
    couplings: tuple[Coupling, ...] = ()
    actuators: tuple[Actuator, ...] = ()
    transmissions: tuple[Transmission, ...] = ()
    keyframes: tuple[Keyframe, ...] = ()
    sensors: tuple[ForceSensor, ...] = ()
    excludes: tuple[tuple[str, str], ...] = ()  # link pairs that never collide with each other
    physics: Physics = Physics()
    ground: Ground = Ground()
    hand: HandId = HandId()

    def link(self, name: str) -> Link:
        for link in self.links:
            if link.name == name:
                return link
        raise KeyError(name)

    def joint(self, name: str) -> Joint:
        for joint in self.joints:
            if joint.name == name:
                return joint
        raise KeyError(name)

    def child_joints(self, link: str) -> list[Joint]:
        return [j for j in self.joints if j.parent == link]

    def parent_joint(self, link: str) -> Joint | None:
        return next((j for j in self.joints if j.child == link), None)
