"""What the planner knows, read from a variant's generated MoveIt config and URDF, as move_group reads them:
SRDF groups (joints or a chain), group states, passive joints and disable_collisions; joint_limits.yaml
(velocity, acceleration, default scaling factors); kinematics.yaml (groups with a solver: IK targets);
moveit_controllers.yaml (which action server drives which joints). Position limits come from the URDF.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import yaml
from lxml import etree

from svhdesc.errors import SvhdescError
from svhdesc.model import ros2_joint_name

# MoveIt's time parameterization uses 1 rad/s^2 where joint_limits.yaml gives no acceleration limit.
MOVEIT_DEFAULT_ACCELERATION = 1.0


@dataclass(frozen=True)
class Controller:
    name: str
    action_ns: str
    joints: tuple[str, ...]


@dataclass(frozen=True)
class MoveItConfig:
    robot: str
    groups: dict[str, tuple[str, ...]]  # every joint of the group, passive ones included
    tips: dict[str, str]  # chain groups: their tip link (the tool frame)
    passive: frozenset[str]
    group_states: dict[str, dict[str, dict[str, float]]]  # group -> state -> joint -> value
    disabled: frozenset[frozenset[str]]  # link pairs never checked
    lower: dict[str, float]
    upper: dict[str, float]
    max_velocity: dict[str, float]
    max_acceleration: dict[str, float]
    velocity_scaling: float
    acceleration_scaling: float
    ik_groups: frozenset[str]
    controllers: tuple[Controller, ...]

    @property
    def joint_names(self) -> set[str]:
        """Every joint the config names: the URDF's limited joints and the groups' joints."""
        return {*self.lower, *(j for joints in self.groups.values() for j in joints)}

    def active(self, group: str) -> list[str]:
        """The joints planned for ``group``: its joints less the passive (coupled) ones."""
        if group not in self.groups:
            raise SvhdescError(f"{self.robot}: no planning group '{group}'; groups: {', '.join(self.groups)}")
        return [j for j in self.groups[group] if j not in self.passive]

    def state(self, group: str, name: str) -> dict[str, float]:
        """A named group state, for ``group`` or any group containing its joints (e.g. arm_hand's)."""
        for states in self.group_states.values():
            if name in states and set(self.active(group)) <= set(states[name]):
                return {j: states[name][j] for j in self.active(group)}
        known = sorted({s for states in self.group_states.values() for s in states})
        raise SvhdescError(f"{self.robot}: no group state '{name}' covering group '{group}'; known: {known}")


def _chain(urdf: etree._ElementTree, base: str, tip: str) -> list[str]:
    parent_joint = {j.find("child").get("link"): j for j in urdf.iterfind("joint")}
    joints: list[str] = []
    link = tip
    while link != base:
        joint = parent_joint.get(link)
        if joint is None:
            raise SvhdescError(f"no kinematic chain from {base} to {tip}")
        if joint.get("type") != "fixed":
            joints.append(joint.get("name"))
        link = joint.find("parent").get("link")
    return joints[::-1]


def load_config(directory: Path, robot: str) -> MoveItConfig:
    config = directory / "config"
    try:
        srdf = etree.parse(str(config / f"{robot}.srdf"))
        urdf = etree.parse(str(directory / f"{robot}.urdf"))
        limits = yaml.safe_load((config / "joint_limits.yaml").read_text())
        kinematics = yaml.safe_load((config / "kinematics.yaml").read_text()) or {}
        controllers = yaml.safe_load((config / "moveit_controllers.yaml").read_text())
    except (OSError, etree.XMLSyntaxError, yaml.YAMLError) as exc:
        raise SvhdescError(f"{robot}: cannot read its MoveIt config: {exc}") from None
    groups: dict[str, tuple[str, ...]] = {}
    tips: dict[str, str] = {}
    elements = {g.get("name"): g for g in srdf.iterfind("group")}

    def resolve(name: str) -> list[str]:
        element = elements[name]
        joints = [j.get("name") for j in element.iterfind("joint")]
        for chain in element.iterfind("chain"):
            joints += _chain(urdf, chain.get("base_link"), chain.get("tip_link"))
            tips[name] = chain.get("tip_link")
        for sub in element.iterfind("group"):
            joints += resolve(sub.get("name"))
        return joints

    for name in elements:
        groups[name] = tuple(resolve(name))
    states: dict[str, dict[str, dict[str, float]]] = {}
    for state in srdf.iterfind("group_state"):
        values = {j.get("name"): float(j.get("value")) for j in state.iterfind("joint")}
        states.setdefault(state.get("group"), {})[state.get("name")] = values
    lower, upper = {}, {}
    for joint in urdf.iterfind("joint"):
        limit = joint.find("limit")
        if limit is not None and joint.get("type") in ("revolute", "prismatic"):
            lower[joint.get("name")] = float(limit.get("lower"))
            upper[joint.get("name")] = float(limit.get("upper"))
    table = limits["joint_limits"]
    return MoveItConfig(
        robot=robot,
        groups=groups,
        tips=tips,
        passive=frozenset(p.get("name") for p in srdf.iterfind("passive_joint")),
        group_states=states,
        disabled=frozenset(frozenset((d.get("link1"), d.get("link2"))) for d in srdf.iterfind("disable_collisions")),
        lower=lower,
        upper=upper,
        max_velocity={j: float(v["max_velocity"]) for j, v in table.items() if v.get("has_velocity_limits")},
        max_acceleration={
            j: float(v["max_acceleration"]) if v.get("has_acceleration_limits") else MOVEIT_DEFAULT_ACCELERATION
            for j, v in table.items()
        },
        velocity_scaling=float(limits.get("default_velocity_scaling_factor", 1.0)),
        acceleration_scaling=float(limits.get("default_acceleration_scaling_factor", 1.0)),
        ik_groups=frozenset(kinematics),
        controllers=tuple(
            Controller(c["name"], c["action_ns"], tuple(c["joints"])) for c in controllers["controller_list"]
        ),
    )


def load_ros2_controllers(directory: Path, config: MoveItConfig) -> tuple[Controller, ...]:
    """The controllers of the variant's ROS 2 package (``ros2/config/moveit_controllers.yaml``, MoveIt 2's simple
    controller manager), their joints by ``config``'s names (the URDF's, as plans name them)."""
    path = directory / "ros2" / "config" / "moveit_controllers.yaml"
    try:
        manager = yaml.safe_load(path.read_text())["moveit_simple_controller_manager"]
        entries = [(name, manager[name]) for name in manager["controller_names"]]
    except (OSError, yaml.YAMLError, KeyError, TypeError) as exc:
        raise SvhdescError(f"{config.robot}: cannot read its ROS 2 MoveIt controllers ({path}): {exc}") from None
    back = {ros2_joint_name(j): j for j in config.joint_names}
    return tuple(
        Controller(name, entry["action_ns"], tuple(back.get(j, j) for j in entry["joints"])) for name, entry in entries
    )
