"""The joint-coupling spec: load, check against a robot, and derive every coupled number."""

from __future__ import annotations

import warnings
from collections.abc import Mapping
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from svhdesc.core.settings.schema import number, numbers, text
from svhdesc.core.settings.yamlio import load_yaml, where
from svhdesc.core.source.urdf import SourceMimic
from svhdesc.errors import SvhdescError
from svhdesc.ir import Channel, Coupling, Joint, Mimic, Robot
from svhdesc.polynomial import image, linearise, polyval

MAX_ORDER = 4
LIMIT_TOL = 1e-9


__all__ = [
    "CouplingSpec",
    "CouplingWarning",
    "apply_spec",
    "image",
    "linearise",
    "load_spec",
    "polyval",
    "propagate",
    "spec_from_mimics",
]


class CouplingWarning(UserWarning):
    """A coupled number had to be approximated or a limit widened."""


@dataclass(frozen=True)
class CouplingSpec:
    path: Path
    channels: tuple[Channel, ...]  # joint = unprefixed channel name
    couplings: tuple[Coupling, ...]  # joint/channel unprefixed
    lines: dict[str, str]  # unprefixed joint or channel -> file:line


CHANNEL_KEYS = {"name", "range", "effort", "velocity", "tip_force"}
COUPLING_KEYS = {"joint", "follows", "poly"}


def load_spec(path: Path) -> CouplingSpec:
    data = load_yaml(path)
    _check_document(data, path)
    lines: dict[str, str] = {}  # channel or coupled joint -> file:line, filled as each is read
    channels_at, couplings_at = where(data, str(path), "channels"), where(data, str(path), "couplings")
    channels = [_channel(item, channels_at, lines) for item in data["channels"]]
    channel_names = {c.name for c in channels}
    couplings: list[Coupling] = []
    for item in data.get("couplings") or []:
        couplings.append(_coupling(item, couplings_at, channel_names, couplings, lines))
    _check_graph(couplings, channel_names, lines)
    return CouplingSpec(path, tuple(channels), tuple(couplings), lines)


def spec_from_mimics(
    robot: Robot, mimics: list[SourceMimic], path: Path, *, narrow: bool = True
) -> CouplingSpec | None:
    """The coupling spec a URDF's ``<mimic>`` tags make when the config gives none: each leader a channel (its
    range, effort and velocity from the leader joint's limits; with ``narrow``, the range where every follower
    stays inside its limits, else the followers' limits are apply_spec's to widen), each mimic joint a linear
    coupling [offset, multiplier]. A mimic of a mimic is composed onto the chain's first leader. None: no mimic
    tags."""
    joints = {j.name: j for j in robot.joints}
    mimics = _movable_mimics(mimics, joints)
    if not mimics:
        return None
    by_joint = {m.joint: m for m in mimics}
    couplings, lines, leaders, broken = [], {}, [], []
    for mimic in mimics:
        leader, factor, offset, seen = mimic.leader, mimic.multiplier, mimic.offset, {mimic.joint}
        while leader in by_joint:  # compose joint = f * (f2 * x + o2) + o onto the chain's first leader
            if leader in seen:
                raise SvhdescError(f"{mimic.where}: <mimic> tags form a cycle through joint {leader}")
            seen.add(leader)
            up = by_joint[leader]
            leader, factor, offset = up.leader, factor * up.multiplier, factor * up.offset + offset
        if leader not in joints or not joints[leader].movable:
            broken.append(replace(mimic, leader=leader))
            continue
        couplings.append(Coupling(mimic.joint, leader, (offset, factor)))
        lines[mimic.joint] = mimic.where
        if leader not in leaders:
            leaders.append(leader)
    if broken:
        raise SvhdescError(_broken(broken, joints))
    channels = []
    for name in leaders:
        joint = joints[name]
        where_ = joint.source or str(path)
        if not joint.lower < joint.upper or joint.effort <= 0 or joint.velocity <= 0:
            raise SvhdescError(
                f"{where_}: joint {name} leads <mimic> joints, so it becomes a channel: it needs a <limit> with "
                "lower < upper, effort > 0 and velocity > 0 (or give a coupling spec in the config)"
            )
        at = joint.source or f"{path}: joint {name}"  # a joint's source names it
        followers = [c for c in couplings if c.channel == name] if narrow else []
        lower, upper = _followers_range(joint, followers, joints, at)
        channels.append(Channel(name, name, lower, upper, joint.effort, joint.velocity))
        lines[name] = where_
    return CouplingSpec(path, tuple(channels), tuple(couplings), lines)


def _followers_range(
    leader: Joint, couplings: list[Coupling], joints: Mapping[str, Joint], at: str
) -> tuple[float, float]:
    """The part of a leader's range in which every follower (``offset + multiplier * leader``) stays inside its own
    limits: the channel's range. A linkage's stop holds the leader there (the Alex's PSYONIC fingers: q2 = 0.72 +
    1.06 q1 reaches its upper limit at q1 = 1.83 of 2.09); one warning names the followers that narrow it."""
    lower, upper, narrowing = leader.lower, leader.upper, []
    for coupling in couplings:
        follower = joints[coupling.joint]
        offset, factor = coupling.coeffs
        reached = sorted((offset + factor * leader.lower, offset + factor * leader.upper))
        inside = reached[0] >= follower.lower - LIMIT_TOL and reached[1] <= follower.upper + LIMIT_TOL
        if follower.type == "continuous" or factor == 0.0 or inside:
            continue  # no limits left (apply_spec's tolerance); a constant outside its limits is apply_spec's error
        low, high = sorted(((follower.lower - offset) / factor, (follower.upper - offset) / factor))
        if low > lower or high < upper:
            narrowing.append(f"{follower.name} [{follower.lower:.6g}, {follower.upper:.6g}]")
        lower, upper = max(lower, low), min(upper, high)
    if not narrowing:
        return lower, upper
    names = ", ".join(narrowing)
    if not lower < upper:
        raise SvhdescError(
            f"{at}: it leads <mimic> joints that leave it no range inside their limits ({names}): "
            f"fix their limits or mimics with joints.NAME.lower, .upper or .mimic in the config (svhdesc init "
            "--joint NAME.KEY=VALUE)"
        )
    warnings.warn(
        f"{at}: its channel's range is [{lower:.9g}, {upper:.9g}] of its limits "
        f"[{leader.lower:.6g}, {leader.upper:.6g}], where its <mimic> followers stay inside theirs: {names}",
        CouplingWarning,
        stacklevel=3,
    )
    return lower, upper


def _broken(broken: list[SourceMimic], joints: Mapping[str, Joint]) -> str:
    """One line for every <mimic> naming no movable joint, with the quirk keys that work around each: follow the
    movable joint whose name ends like the one named and begins like the follower's own (``Left_index_q1`` for
    ``Left_index_q2``'s ``index_q1``), else drop the tag."""
    fixes = []
    for mimic in broken:
        endings = [n for n, j in joints.items() if j.movable and n != mimic.joint and n.endswith(mimic.leader)]
        shared = [len(_common_prefix(n, mimic.joint)) for n in endings]
        fixes.append(f"--joint {mimic.joint}.mimic={endings[shared.index(max(shared))] if endings else 'drop'}")
    first = broken[0]
    more = f" ({len(broken)} such tags)" if len(broken) > 1 else ""
    return (
        f"{first.where}: <mimic> names joint {first.leader!r}, which is no movable joint{more}: re-point or drop "
        f"them, as joints.NAME.mimic: LEADER | drop in the config, or to svhdesc init: {' '.join(fixes)}"
    )


def _common_prefix(a: str, b: str) -> str:
    count = next((i for i, (x, y) in enumerate(zip(a, b)) if x != y), min(len(a), len(b)))
    return a[:count]


def _movable_mimics(mimics: list[SourceMimic], joints: Mapping[str, Joint]) -> list[SourceMimic]:
    """The mimic tags of movable joints; a ``<mimic>`` on a fixed joint (Talos' gripper draws its linkage so, for
    Gazebo's mimic plugin) moves nothing in the model: ignored, one warning line naming all such joints."""
    fixed = [m for m in mimics if m.joint in joints and not joints[m.joint].movable]
    if fixed:
        names = ", ".join(m.joint for m in fixed)
        warnings.warn(
            f"{fixed[0].where}: <mimic> on {len(fixed)} fixed joint(s) ignored (a fixed joint cannot follow): {names}",
            CouplingWarning,
            stacklevel=3,
        )
    return [m for m in mimics if m not in fixed]


def _check_document(data: object, path: Path) -> None:
    if not isinstance(data, dict) or not isinstance(data.get("channels"), list):
        raise SvhdescError(f"{where(data, str(path))}: coupling spec needs a 'channels' list")
    unknown = [str(k) for k in data if k not in {"channels", "couplings"}]
    if unknown:
        raise SvhdescError(
            f"{where(data, str(path), unknown[0])}: unknown key(s) {sorted(unknown)} in the coupling spec"
        )
    if data.get("couplings") is not None and not isinstance(data["couplings"], list):
        raise SvhdescError(f"{where(data, str(path), 'couplings')}: 'couplings' must be a list")


def _channel(item: object, base: str, lines: dict[str, str]) -> Channel:
    at = where(item, base)
    if not isinstance(item, dict) or "name" not in item:
        raise SvhdescError(f"{at}: channel needs a name")
    unknown = set(item) - CHANNEL_KEYS
    if unknown:
        raise SvhdescError(f"{at}: channel {item['name']}: unknown key(s) {sorted(map(str, unknown))}")
    name = text(item["name"], f"{at}: channel name")
    if name in lines:
        raise SvhdescError(f"{at}: channel {name} declared twice (first at {lines[name]})")
    missing = [key for key in ("range", "effort", "velocity") if key not in item]
    if missing:
        raise SvhdescError(f"{at}: channel {name} needs {', '.join(missing)}")
    lower, upper = numbers((2,))(item["range"], f"{where(item, at, 'range')}: channel {name}: range")
    if not lower < upper:
        raise SvhdescError(f"{where(item, at, 'range')}: channel {name}: empty range [{lower}, {upper}]")

    def positive(key: str) -> float:
        return number(0.0, 1e4, strict=True)(item[key], f"{where(item, at, key)}: channel {name}: {key}")

    effort, velocity = positive("effort"), positive("velocity")
    tip_force = positive("tip_force") if item.get("tip_force") is not None else None
    channel = Channel(name, name, lower, upper, effort, velocity, tip_force)
    lines[name] = at
    return channel


def _coupling(
    item: object, base: str, channel_names: set[str], earlier: list[Coupling], lines: dict[str, str]
) -> Coupling:
    at = where(item, base)
    if not isinstance(item, dict) or not COUPLING_KEYS <= set(item):
        raise SvhdescError(f"{at}: coupling needs joint, follows and poly")
    unknown = set(item) - COUPLING_KEYS
    if unknown:
        raise SvhdescError(f"{at}: coupling: unknown key(s) {sorted(map(str, unknown))}")
    joint = text(item["joint"], f"{at}: coupled joint name")
    leader = text(item["follows"], f"{at}: coupled joint {joint}: follows")
    coeffs = tuple(numbers()(item["poly"], f"{where(item, at, 'poly')}: coupled joint {joint}: poly"))
    if not 1 <= len(coeffs) <= MAX_ORDER + 1:
        raise SvhdescError(f"{at}: coupled joint {joint}: poly has {len(coeffs)} terms (1 to 5 allowed)")
    if joint in channel_names:
        raise SvhdescError(f"{at}: joint {joint} is a channel and cannot also follow {leader}: driven twice")
    if joint in lines:
        first = next(c for c in earlier if c.joint == joint)
        problem = "duplicated" if first.channel == leader else f"driven twice (also by {first.channel})"
        raise SvhdescError(f"{at}: coupled joint {joint} {problem} (first at {lines[joint]})")
    lines[joint] = at
    return Coupling(joint, leader, coeffs)


def _check_graph(couplings: list[Coupling], channels: set[str], lines: dict[str, str]) -> None:
    follows = {c.joint: c.channel for c in couplings}
    for coupling in couplings:
        if coupling.channel in channels:
            continue
        if coupling.channel not in follows:
            raise SvhdescError(
                f"{lines[coupling.joint]}: coupled joint {coupling.joint} follows unknown channel {coupling.channel}"
            )
        # Walk the chain to tell a cycle from a plain chain.
        seen, node = [coupling.joint], coupling.channel
        while node in follows and node not in seen:
            seen.append(node)
            node = follows[node]
        kind = "a cycle" if node in seen else "a chain"
        path = " -> ".join([*seen, node])
        raise SvhdescError(
            f"{lines[coupling.joint]}: coupled joint {coupling.joint} is in {kind} of couplings ({path}); "
            "every coupled joint must follow a channel directly"
        )


def _refuse_prefix(prefix: str | None, prefix_at: str, joints: Mapping[str, object], wanted: str) -> None:
    """A hand.prefix that begins no joint of the robot is the culprit, not the spec: say so at the config's line."""
    if prefix and prefix_at and not any(name.startswith(f"{prefix}_") for name in joints):
        raise SvhdescError(
            f"{prefix_at}: hand.prefix {prefix!r} begins no joint of the robot (the coupling spec's first channel "
            f"would be {wanted})"
        )


def apply_spec(
    robot: Robot, spec: CouplingSpec, prefix: str | None, *, widen_limits: bool = False, prefix_at: str = ""
) -> Robot:
    """Find the spec's joints in the robot, check the spec against it, and set every coupled joint's mimic.

    A spec name is the robot's joint ``<prefix>_<name>`` when the robot has that joint, else ``name`` itself:
    the prefix is a convenience for a hand mounted under one, not a requirement.
    """
    joints = {j.name: j for j in robot.joints}

    def full(name: str) -> str:
        prefixed = f"{prefix}_{name}" if prefix else name
        return name if prefixed not in joints and name in joints else prefixed

    channels = []
    for channel in spec.channels:
        joint = joints.get(full(channel.name))
        if joint is None or not joint.movable:
            _refuse_prefix(prefix, prefix_at, joints, f"{full(channel.name)} ({spec.lines[channel.name]})")
            raise SvhdescError(f"{spec.lines[channel.name]}: unknown joint {full(channel.name)} (channel)")
        if channel.lower < joint.lower - LIMIT_TOL or channel.upper > joint.upper + LIMIT_TOL:
            raise SvhdescError(
                f"{spec.lines[channel.name]}: channel {channel.name} range [{channel.lower}, {channel.upper}] "
                f"leaves the limit [{joint.lower}, {joint.upper}] of joint {joint.name} ({joint.source})"
            )
        channels.append(replace(channel, joint=joint.name))
    by_channel = {c.name: c for c in channels}
    couplings, updated = [], dict(joints)
    for coupling in spec.couplings:
        at = spec.lines[coupling.joint]
        joint = joints.get(full(coupling.joint))
        if joint is None or not joint.movable:
            raise SvhdescError(f"{at}: unknown joint {full(coupling.joint)} (coupled joint)")
        channel = by_channel[coupling.channel]
        low, high = image(coupling.coeffs, channel.lower, channel.upper)
        if low < joint.lower - LIMIT_TOL or high > joint.upper + LIMIT_TOL:
            message = (
                f"coupled joint {joint.name}: image [{low:.9g}, {high:.9g}] of channel {channel.name} "
                f"range [{channel.lower}, {channel.upper}] leaves its limit [{joint.lower}, {joint.upper}]"
            )
            if not widen_limits:
                raise SvhdescError(f"{at}: {message} ({joint.source})")
            warnings.warn(f"{message}; limit widened", CouplingWarning, stacklevel=2)
            joint = replace(joint, lower=min(joint.lower, low), upper=max(joint.upper, high))
        if any(c != 0.0 for c in coupling.coeffs[2:]):
            offset, multiplier = linearise(coupling.coeffs, channel.lower, channel.upper)
            warnings.warn(
                f"{at}: coupled joint {joint.name}: URDF <mimic> is linear; using the least-squares line "
                f"offset={offset:.6g} multiplier={multiplier:.6g} over [{channel.lower}, {channel.upper}]",
                CouplingWarning,
                stacklevel=2,
            )
        updated[joint.name] = replace(joint, mimic=Mimic(channel.joint, coupling.coeffs))
        couplings.append(replace(coupling, joint=joint.name, channel=channel.name))
    return replace(
        robot,
        joints=tuple(updated[j.name] for j in robot.joints),
        channels=tuple(channels),
        couplings=tuple(couplings),
    )


def propagate(robot: Robot, positions: dict[str, float]) -> dict[str, float]:
    """Positions of every movable joint: channels as given (default 0), coupled joints from the spec."""
    result = {j.name: positions.get(j.name, 0.0) for j in robot.joints if j.movable}
    for joint in robot.joints:
        if joint.mimic is not None:
            result[joint.name] = float(polyval(joint.mimic.coeffs, result[joint.mimic.joint]))
    return result


def coupling_matrix(robot: Robot) -> tuple[list[str], list[str], np.ndarray]:
    """S_m (joints x channels): d joint / d channel at the origin (the linear term)."""
    hand = [j for j in robot.joints if j.movable and (j.mimic or j.name in {c.joint for c in robot.channels})]
    rows = [j.name for j in hand]
    cols = [c.joint for c in robot.channels]
    matrix = np.zeros((len(rows), len(cols)))
    for r, joint in enumerate(hand):
        if joint.mimic is None:
            matrix[r, cols.index(joint.name)] = 1.0
        else:
            coeffs = joint.mimic.coeffs
            matrix[r, cols.index(joint.mimic.joint)] = coeffs[1] if len(coeffs) > 1 else 0.0
    return rows, cols, matrix
