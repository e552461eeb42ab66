"""The one schema of the build settings: typed sections, their defaults, and a check of every value.

Each section is a frozen dataclass; its fields are the keys a config may write (anything else is
refused), their defaults are the only defaults, and each field's ``check`` is applied where the
value is read, naming the config file and line. ``normalise`` returns the typed settings.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field, fields, replace
from typing import Any

from svhdesc.core.inertia import inertial_problem
from svhdesc.core.settings.yamlio import Node, where
from svhdesc.errors import SvhdescError

CONTACT_MODELS = {"point": 1, "hard_finger": 3, "soft_finger": 4}
INTERFACES = ("position", "effort")
SERVOS = ("position", "velocity")  # joints.NAME.servo

Check = Callable[[Any, str], Any]  # (raw value, "file:line: key") -> normalised value
LARGEST = 1e6  # no setting of a robot model is larger in magnitude (metres, kg, N m/rad, ...)


def _fail(at: str, message: str) -> SvhdescError:
    return SvhdescError(f"{at} {message}")


def _shown(value: Any) -> str:
    """``repr`` of a value, cut short: a 400-digit integer is no message."""
    text = repr(value)
    return text if len(text) <= 40 else f"{text[:20]}... ({len(text)} characters)"


def number(minimum: float | None = None, maximum: float | None = None, *, strict: bool = False) -> Check:
    """A finite real number (not a bool), optionally >= or > ``minimum`` and <= ``maximum``.

    The maxima are plausibility bounds: far beyond any robot, well inside what the simulators compute with.
    """

    def check(value: Any, at: str) -> float:
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise _fail(at, f"must be a number, got {value!r}")
        try:
            result = float(value)
        except OverflowError:  # an integer beyond any float
            result = math.inf
        if not math.isfinite(result):
            raise _fail(at, f"must be finite, got {_shown(value)}")
        if minimum is not None and (result <= minimum if strict else result < minimum):
            raise _fail(at, f"must be {'>' if strict else '>='} {minimum:g}, got {value!r}")
        if maximum is not None and result > maximum:
            raise _fail(at, f"must be <= {maximum:g}, got {value!r}")
        if maximum is None and abs(result) > LARGEST:
            raise _fail(at, f"must be within +-{LARGEST:g}, got {value!r}")
        return result

    return check


def integer(minimum: int = 0, maximum: int = 10**6) -> Check:
    def check(value: Any, at: str) -> int:
        if isinstance(value, bool) or not isinstance(value, int):
            raise _fail(at, f"must be an integer, got {value!r}")
        if not minimum <= value <= maximum:
            raise _fail(at, f"must be in [{minimum}, {maximum}], got {value!r}")
        return value

    return check


def boolean(value: Any, at: str) -> bool:
    if not isinstance(value, bool):
        raise _fail(at, f"must be true or false, got {value!r}")
    return value


def text(value: Any, at: str) -> str:
    if not isinstance(value, str) or not value:
        raise _fail(at, f"must be a non-empty string, got {value!r}")
    return value


def optional(inner: Check) -> Check:
    def check(value: Any, at: str) -> Any:
        return None if value is None else inner(value, at)

    return check


def choice(*options: str) -> Check:
    def check(value: Any, at: str) -> str:
        if value not in options:
            raise _fail(at, f"must be one of {list(options)}, got {value!r}")
        return value

    return check


def numbers(lengths: tuple[int, ...] | None = None, item: Check | None = None) -> Check:
    """A list of finite numbers, of one of ``lengths``."""
    item = item or number()

    def check(value: Any, at: str) -> list[float]:
        if not isinstance(value, list):
            raise _fail(at, f"must be a list of numbers, got {value!r}")
        if lengths is not None and len(value) not in lengths:
            expected = " or ".join(str(n) for n in lengths)
            raise _fail(at, f"must have {expected} numbers, got {len(value)}")
        return [item(v, at) for v in value]

    return check


def solref(value: Any, at: str) -> list[float]:
    """MuJoCo solref (timeconst, dampratio): both > 0."""
    return numbers((2,), number(0.0, 100.0, strict=True))(value, at)


def solimp(value: Any, at: str) -> list[float]:
    """MuJoCo solimp (dmin, dmax, width[, midpoint, power]): impedances in (0, 1), width > 0, power >= 1."""
    result = numbers((3, 5))(value, at)
    if not (0 < result[0] < 1 and 0 < result[1] < 1 and result[2] > 0):
        raise _fail(at, f"must hold dmin, dmax in (0, 1) and width > 0, got {value!r}")
    if len(result) == 5 and not (0 < result[3] < 1 and result[4] >= 1):
        raise _fail(at, f"must hold midpoint in (0, 1) and power >= 1, got {value!r}")
    return result


def names(value: Any, at: str) -> list[str]:
    if not isinstance(value, list):
        raise _fail(at, f"must be a list of names, got {value!r}")
    return [text(v, at) for v in value]


def number_or_numbers(minimum: float) -> Check:
    def check(value: Any, at: str) -> float | list[float]:
        if isinstance(value, list):
            return numbers(None, number(minimum))(value, at)
        return number(minimum)(value, at)

    return check


def mapping_of(inner: Check) -> Check:
    """A mapping from names to values each checked by ``inner`` (lines of the keys kept)."""

    def check(value: Any, at: str) -> Node:
        if value is None:
            return Node()
        if not isinstance(value, dict):
            raise _fail(at, f"must be a mapping, got {value!r}")
        result = Node()
        result.where = getattr(value, "where", "")
        for key, item in value.items():
            line = where(value, at.rsplit(": ", 1)[0], key)
            result[str(key)] = inner(item, f"{line}: {_key(at)}.{key}")
            result.lines[str(key)] = line
        return result

    return check


def _key(at: str) -> str:
    """The dotted key of an ``at`` label 'file:line: a.b'."""
    return at.rsplit(": ", 1)[-1] if ": " in at else at


def free(value: Any, at: str) -> Any:
    """Checked by the stage that reads it (collision rules)."""
    if value is not None and not isinstance(value, dict):
        raise _fail(at, f"must be a mapping, got {value!r}")
    return value if value is not None else Node()


def _field(default: Any, check: Check, *, required: bool = False) -> Any:
    metadata = {"check": check, "required": required, "section": False}
    if isinstance(default, (list, dict)):
        return field(default_factory=lambda: type(default)(default), metadata=metadata)
    return field(default=default, metadata=metadata)


def _sub(cls: type) -> Any:
    """A nested section: checked (and its defaults filled) even when the config leaves it out."""

    def check(value: Any, at: str) -> tuple[Any, Node]:
        return _section(cls, value, at)

    return field(default=None, metadata={"check": check, "required": False, "section": True})


@dataclass(frozen=True)
class Located:
    """Where a section was written: ``at(key)`` is the file:line of that key (else of the section)."""

    where: str = field(default="", kw_only=True, compare=False, repr=False, metadata={"located": True})
    lines: dict[str, str] = field(
        default_factory=dict, kw_only=True, compare=False, repr=False, metadata={"located": True}
    )

    def at(self, key: str) -> str:
        return self.lines.get(key, self.where)


def _config_fields(cls: type) -> list[Any]:
    return [f for f in fields(cls) if not f.metadata.get("located")]


def expand_hand(pattern: str, prefix: str | None, at: str) -> str:
    """``pattern`` with ``{hand}`` replaced by the hand's prefix; a robot without one cannot use it."""
    if "{hand}" in pattern and not prefix:
        raise SvhdescError(f"{at}: {pattern!r} names {{hand}}, but hand.prefix is not set")
    return pattern.format(hand=prefix or "")


@dataclass(frozen=True)
class Hand(Located):
    """The hand's drives and parts; every key is optional (a robot without a hand leaves the section out).

    ``prefix`` is a convenience: with it, fingertips, the force sensor and the coupling spec's joints are
    ``<prefix>_<name>``; without it, they are the robot's own names. ``side`` (right or left; a mount's side when
    the variant has a mount) is which hand it is. Both travel with the built model (the IR's ``hand``, the
    manifest's ``hand``), so that nothing downstream guesses them from names.
    """

    prefix: str | None = _field(None, optional(text))
    side: str | None = _field(None, optional(choice("right", "left")))
    fingertips: list[str] = _field([], names)
    force_sensor: str | None = _field(None, optional(text))
    joint_damping: float = _field(0.0, number(0.0))  # channel joints (the drives)
    joint_armature: float = _field(0.0, number(0.0))
    coupled_joint_damping: float = _field(0.0, number(0.0))  # joints that follow a channel
    coupled_joint_armature: float = _field(0.0, number(0.0))
    kp: float = _field(10.0, number(0.0))
    dampratio: float = _field(1.0, number(0.0, 100.0))
    limit_margin: float = _field(0.0, number(0.0, 0.1))
    limit_solref: list[float] | None = _field(None, optional(solref))

    def link(self, name: str) -> str:
        """A hand part's link (or joint) name: ``<prefix>_<name>``, or ``name`` itself without a prefix."""
        return f"{self.prefix}_{name}" if self.prefix else name


@dataclass(frozen=True)
class Arm(Located):
    """The arm's servos. Listing ``joints`` is enough: ``enabled`` (default: on when joints are listed) turns off a
    section a config shares with variants that have no arm."""

    enabled: bool | None = _field(None, optional(boolean))
    joints: list[str] = _field([], names)
    kp: float | list[float] = _field(1000.0, number_or_numbers(0.0))
    dampratio: float = _field(1.0, number(0.0, 100.0))
    joint_damping: float = _field(0.0, number(0.0))
    joint_armature: float = _field(0.0, number(0.0))
    limit_margin: float = _field(0.0, number(0.0, 0.1))
    limit_solref: list[float] | None = _field(None, optional(solref))

    @property
    def active(self) -> bool:
        return bool(self.joints) if self.enabled is None else self.enabled


SIDES = ("right", "left")


@dataclass(frozen=True)
class Mount(Located):
    """Where this project's SVH goes on an arm read from any URDF or xacro (the variant's ``xacro``): fixed to the
    arm's link ``parent`` at ``xyz`` (m) / ``rpy`` (rad, URDF order), the ``side`` hand, its links and joints named
    ``<prefix>_...`` (default: hand.prefix, else ``<side>_hand``; written, it overrides hand.prefix). ``remove``:
    arm links dropped with every link below them (the arm's own gripper, which the SVH replaces)."""

    parent: str = _field(None, text, required=True)
    xyz: list[float] = _field([0.0, 0.0, 0.0], numbers((3,), number(-10.0, 10.0)))
    rpy: list[float] = _field([0.0, 0.0, 0.0], numbers((3,), number(-10.0, 10.0)))
    side: str = _field("right", choice(*SIDES))
    prefix: str | None = _field(None, optional(text))
    remove: list[str] = _field([], names)


def _optional_section(cls: type) -> Any:
    """A nested section that is None unless the config writes it (its required keys then apply)."""

    def check(value: Any, at: str) -> tuple[Any, Any]:
        return (None, None) if value is None else _section(cls, value, at)

    return field(default=None, metadata={"check": check, "required": False, "section": True})


def _budget(value: Any, at: str) -> Node:
    return _section(Budget, value, at)[1]


def _inertial(value: Any, at: str) -> Node:
    """One explicit inertial, held to the rule source inertials are (it wins over everything: nothing repairs it)."""
    inertial = _section(ExplicitInertial, value, at)[1]
    problem = inertial_problem(float(inertial["mass"]), [float(x) for x in inertial["inertia"]])
    if problem is not None:
        raise SvhdescError(f"{at}: {problem}")
    return inertial


@dataclass(frozen=True)
class Budget(Located):
    links: str = _field(None, text, required=True)
    total: float = _field(None, number(0.0, 1e4, strict=True), required=True)


@dataclass(frozen=True)
class ExplicitInertial(Located):
    mass: float = _field(None, number(0.0, 1e4, strict=True), required=True)
    com: list[float] = _field(None, numbers((3,)), required=True)
    inertia: list[float] = _field(None, numbers((6,)), required=True)


def _budgets(value: Any, at: str) -> list[Node]:
    if value is None:
        return []
    if not isinstance(value, list):
        raise _fail(at, f"must be a list of {{links, total}}, got {value!r}")
    return [_budget(item, f"{where(item, at.split(': ')[0])}: {_key(at)}[{i}]") for i, item in enumerate(value)]


RECOMPUTE = "recompute"


def _inertials(value: Any, at: str) -> str | Node:
    """``recompute`` (each link whose source inertial is invalid), or per link ``recompute`` or {mass, com, inertia}."""
    if value == RECOMPUTE:
        return RECOMPUTE
    return mapping_of(lambda item, label: RECOMPUTE if item == RECOMPUTE else _inertial(item, label))(value, at)


@dataclass(frozen=True)
class Mass(Located):
    budgets: list[Any] = _field([], _budgets)
    links: dict[str, float] = _field({}, mapping_of(number(0.0, 1e4, strict=True)))
    # {link: {mass, com, inertia}} wins over everything (inertia in the order ixx, ixy, ixz, iyy, iyz, izz, in
    # the link frame; com in the link frame). A source inertial that is invalid is always replaced, with a
    # warning: by the cylinder fitted to the link's geometry at the link's mass, or, for a link without geometry,
    # by a sphere (docs/any-robot.md). `recompute` replaces one link's inertial whatever its source says
    # (`inertials: {link: recompute}`); `inertials: recompute` is kept for older configs (the default now).
    inertials: dict[str, Any] | str = _field({}, _inertials)

    @property
    def explicit_inertials(self) -> dict[str, Any]:
        """Links given a full inertial: {link: {mass, com, inertia}}."""
        if isinstance(self.inertials, str):
            return {}
        return {name: value for name, value in self.inertials.items() if value != RECOMPUTE}

    @property
    def recompute_all(self) -> bool:
        return self.inertials == RECOMPUTE

    @property
    def recompute_links(self) -> set[str]:
        if isinstance(self.inertials, str):
            return set()
        return {name for name, value in self.inertials.items() if value == RECOMPUTE}


@dataclass(frozen=True)
class Contact(Located):
    model: str = _field("soft_finger", choice(*CONTACT_MODELS))
    sliding: float = _field(1.0, number(0.0, 10.0))
    torsional: float = _field(0.0, number(0.0, 10.0))
    rolling: float = _field(0.0, number(0.0, 10.0))
    default_sliding: float = _field(0.8, number(0.0, 10.0))


@dataclass(frozen=True)
class Transmissions(Located):
    interface: str = _field("position", choice(*INTERFACES))


@dataclass(frozen=True)
class Simulation(Located):
    timestep: float = _field(0.002, number(0.0, 0.1, strict=True))
    noslip_iterations: int = _field(0, integer(0, 1000))
    coupling_solref: list[float] = _field([0.002, 1.0], solref)
    coupling_solimp: list[float] = _field([0.99, 0.999, 0.0001, 0.5, 2.0], solimp)
    gravity_compensation: bool = _field(True, boolean)
    # MuJoCo's friction cone: elliptic (the default, what Warp and MJX implement best) or pyramidal (which
    # kept the Allegro hand's crowded fingertips stable where the elliptic cone diverged)
    cone: str = _field("elliptic", choice("elliptic", "pyramidal"))
    # The source's <dynamics friction> becomes MuJoCo's frictionloss, capped at this fraction of the joint's
    # effort (with a warning): a position servo of kp = effort / 0.1 rad stalls friction / kp off its target,
    # and a source friction of 2/3 of the effort (the Allegro's) left the joints at 28 % of their range.
    # joints.NAME.friction sets one joint's friction whatever this says.
    friction_cap: float = _field(0.1, number(0.0, 1.0))


@dataclass(frozen=True)
class Validation(Located):
    """What `svhdesc validate` assumes of the robot where its own numbers cannot say it."""

    # N on each fingertip in load_limits; None: twice the force the fingertip's weakest hand drive exerts there,
    # at most 50 N (svhdesc/validate/load_limits.py)
    tip_load: float | None = _field(None, optional(number(0.0, 1000.0, strict=True)))


@dataclass(frozen=True)
class Scene(Located):
    floor_z: float = _field(0.0, number(-100.0, 100.0))
    pedestal_radius: float = _field(0.0, number(0.0, 10.0))


def _keyframe(value: Any, at: str) -> Node:
    return mapping_of(number())(value, at)


FINGER_NAMES = ("thumb", "index", "middle", "ring", "pinky")
GRASP_KEYS = {
    # what is held: a free body of this shape, size (MuJoCo geom size, m) and mass (kg)
    "object": choice("cylinder", "sphere", "box"),
    "size": numbers((1, 2, 3), number(0.0, 1.0, strict=True)),
    "mass": number(0.0, 100.0, strict=True),
    # where it is held: centre, and the direction of its axis (cylinder) or z (box), in the hand's
    # base_link frame of a right hand (mirrored for a left one)
    "pos": numbers((3,)),
    "axis": numbers((3,)),
    # fingers that must touch the object
    "fingers": names,
    # fingertips that meet (< 1 mm, nothing else touching) when the posture closes on nothing
    "tips": names,
}


def _grasp(value: Any, at: str) -> Node:
    """A grasp (named like the keyframe that closes it) and the object it holds."""
    if not isinstance(value, dict):
        raise _fail(at, f"must be a mapping, got {value!r}")
    base = at.rsplit(": ", 1)[0]
    unknown = [str(k) for k in value if k not in GRASP_KEYS]
    if unknown:
        raise SvhdescError(f"{where(value, base, unknown[0])}: unknown key(s) {sorted(unknown)} in {_key(at)}")
    missing = [k for k in ("object", "size", "mass", "pos") if k not in value]
    if missing:
        raise _fail(at, f"needs {', '.join(missing)}")
    result = Node()
    result.where = getattr(value, "where", "")
    for key, item in value.items():
        line = where(value, base, key)
        result[key] = GRASP_KEYS[key](item, f"{line}: {_key(at)}.{key}")
        result.lines[key] = line
    for key in ("fingers", "tips"):
        for finger in result.get(key, []):
            if finger not in FINGER_NAMES:
                raise _fail(f"{result.lines[key]}: {_key(at)}.{key}", f"has {finger!r}; fingers: {list(FINGER_NAMES)}")
    needed = {"cylinder": 2, "sphere": 1, "box": 3}[result["object"]]
    if len(result["size"]) != needed:
        raise _fail(f"{result.lines['size']}: {_key(at)}.size", f"a {result['object']} needs {needed} number(s)")
    return result


@dataclass(frozen=True)
class JointDynamics(Located):
    """One joint's quirks: its dynamics over the source's <dynamics> and the hand/arm sections' defaults, and what
    patches the source's <joint> before it is read (svhdesc.core.source.quirks)."""

    damping: float | None = _field(None, optional(number(0.0)))  # N m s/rad (N s/m for a sliding joint)
    friction: float | None = _field(None, optional(number(0.0)))  # N m (N): MuJoCo's frictionloss
    # the drive's rating where the source gives none (<limit effort="0">): N m (N), rad/s (m/s)
    effort: float | None = _field(None, optional(number(0.0, 1e6, strict=True)))
    velocity: float | None = _field(None, optional(number(0.0, 1e4, strict=True)))
    # the joint's limits where the source's are unusable (rad, m)
    lower: float | None = _field(None, optional(number(-1e3, 1e3)))
    upper: float | None = _field(None, optional(number(-1e3, 1e3)))
    # its <mimic> tag: "drop" (ignored), or the joint it follows instead (with the tag's multiplier and offset)
    mimic: str | None = _field(None, optional(text))
    # its new name, where the source's cannot stand (a joint named like a link, which SDFormat refuses)
    rename: str | None = _field(None, optional(text))
    # continuous: a revolute joint that turns without end, written without usable limits; fixed: locked at 0
    type: str | None = _field(None, optional(choice("continuous", "fixed")))
    # a continuous joint's drive: position (a servo without limits: any angle is a target; the default) or velocity
    # (a velocity servo commanded in rad/s, as a wheel's motor is)
    servo: str | None = _field(None, optional(choice(*SERVOS)))


def _joint_dynamics(value: Any, at: str) -> JointDynamics:
    return _section(JointDynamics, value, at)[0]


def joint_options(options: tuple[str, ...] | list[str]) -> dict[str, JointDynamics]:
    """``--joint NAME.KEY=VALUE`` options (svhdesc init) as the ``joints:`` settings they stand for, each value read
    as YAML and checked as the config's own would be."""
    import yaml

    raw: dict[str, Node] = {}
    for option in options:
        target, sep, value = option.partition("=")
        name, dot, key = target.rpartition(".")
        if not sep or not dot or not name or not key:
            raise SvhdescError(f"--joint {option!r}: expected NAME.KEY=VALUE (joints.NAME.KEY of the config)")
        try:
            raw.setdefault(name, Node())[key] = yaml.safe_load(value)
        except yaml.YAMLError:
            raw.setdefault(name, Node())[key] = value
    return {name: _joint_dynamics(entry, f"--joint: joints.{name}") for name, entry in raw.items()}


@dataclass(frozen=True)
class Settings(Located):
    coupling: str | None = _field(None, optional(text))  # the coupling spec; none for a robot without couplings
    coupled_limits: str = _field("error", choice("error", "widen"))
    packages: dict[str, str] = _field({}, mapping_of(text))
    hand: Hand = _sub(Hand)
    arm: Arm = _sub(Arm)
    mount: Mount | None = _optional_section(Mount)
    mass: Mass = _sub(Mass)
    contact: Contact = _sub(Contact)
    transmissions: Transmissions = _sub(Transmissions)
    simulation: Simulation = _sub(Simulation)
    scene: Scene = _sub(Scene)
    validate: Validation = _sub(Validation)
    keyframes: dict[str, Any] = _field({}, mapping_of(_keyframe))
    grasps: dict[str, Any] = _field({}, mapping_of(_grasp))
    collision: dict[str, Any] = field(default=None, metadata={"check": free, "required": False, "section": True})
    joints: dict[str, Any] = _field({}, mapping_of(_joint_dynamics))  # {joint: {damping, friction}}


def _section(cls: type, value: Any, at: str) -> tuple[Any, Node]:
    """(typed instance, plain mapping with defaults filled) of one section; ``at`` = 'file:line: key'."""
    base, _, key = at.rpartition(": ")
    base = base or at
    if value is None:
        value = Node()
    if not isinstance(value, dict):
        raise _fail(f"{base}:", f"'{key}' must be a mapping, got {value!r}")
    here = where(value, base)
    known = {f.name for f in _config_fields(cls)}
    unknown = [str(k) for k in value if k not in known]
    if unknown:
        inside = f" in '{key}'" if key else ""
        raise SvhdescError(f"{where(value, here, unknown[0])}: unknown key(s) {sorted(unknown)}{inside}")
    typed: dict[str, Any] = {}
    plain = Node()
    plain.where = here
    for spec in _config_fields(cls):
        label = f"{key}.{spec.name}" if key else spec.name
        if spec.name in value:
            line = where(value, here, spec.name)
            result = spec.metadata["check"](value[spec.name], f"{line}: {label}")
            plain.lines[spec.name] = line
        elif spec.metadata["required"]:
            raise SvhdescError(f"{here}: '{label}' is required")
        elif spec.metadata["section"]:
            result = spec.metadata["check"](None, f"{here}: {label}")
        else:
            result = spec.default_factory() if callable(spec.default_factory) else spec.default  # type: ignore[misc]
        if isinstance(result, tuple):  # a nested section: (typed, plain)
            typed[spec.name], plain[spec.name] = result
        else:
            typed[spec.name] = result
            plain[spec.name] = result
    return cls(**typed, where=here, lines=dict(plain.lines)), plain


def normalise(settings: dict[str, Any], at: str) -> Settings:
    """Check every value of one variant's merged settings; fill the defaults."""
    typed = _section(Settings, settings, f"{at}: ")[0]
    if typed.mount is not None:  # the mount says which hand it mounts (a base config's hand.side is its own hands')
        hand = replace(typed.hand, prefix=mounted_prefix(typed.mount, typed.hand), side=typed.mount.side)
        typed = replace(typed, hand=hand)
    if not typed.hand.prefix:
        _check_no_hand_patterns(typed)
    return typed


def mounted_prefix(mount: Mount, hand: Hand) -> str:
    """The mounted hand's prefix: mount.prefix (it overrides hand.prefix, which a base config may set for its own
    hands), else hand.prefix, else ``<side>_hand``."""
    prefix = mount.prefix or hand.prefix or f"{mount.side}_hand"
    other = SIDES[1 - SIDES.index(mount.side)]
    if prefix.startswith(other):  # e.g. a base config's right_hand inherited by a left mount
        raise SvhdescError(
            f"{mount.at('side')}: mount.side is {mount.side}, but the hand's prefix is {prefix!r}: set mount.prefix"
        )
    return prefix


def _check_no_hand_patterns(settings: Settings) -> None:
    """Without hand.prefix, a pattern naming ``{hand}`` has nothing to stand for: refuse it where it is written.

    (Malformed collision entries are left to the collision rules, which name them.)
    """
    for budget in settings.mass.budgets:
        expand_hand(str(budget["links"]), None, f"{budget.lines.get('links', budget.where)}: mass.budgets")
    collision, at = settings.collision, settings.at("collision")
    classes = collision.get("classes")
    for entry in classes if isinstance(classes, list) else []:
        links = entry.get("links") if isinstance(entry, dict) else None
        for pattern in links if isinstance(links, list) else []:
            expand_hand(str(pattern), None, f"{where(entry, at)}: collision.classes")
    overrides = collision.get("links")
    for name in overrides if isinstance(overrides, dict) else {}:
        expand_hand(str(name), None, f"{where(overrides, at, name)}: collision.links")
