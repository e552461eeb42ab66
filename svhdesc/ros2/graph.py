"""The ROS 2 graph a real ros2_control system shows, in one process: a node per controller named after it (declaring
its ``ros2_controllers.yaml`` parameters), ``controller_manager``, ``robot_state_publisher`` (/robot_description,
/tf, /tf_static from the simulated joints), and SCHUNK's hardware interface's ``svh`` node (/svh/initialized).
``/dynamic_joint_states`` carries SCHUNK's state interfaces per channel, the current estimated through the
driver library's own effort constants (below).
"""

from __future__ import annotations

import math
import struct
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np
from lxml import etree

from svhdesc.errors import SvhdescError
from svhdesc.model import JTC_DEFAULTS

# schunk_svh_library (fzi-forschungszentrum-informatik, src/control/SVHController.cpp, CHANNEL_EFFORT_CONSTANTS):
# per channel (a, b) with effort [N] = a * |current [mA]| + b (SVHFingerManager::convertmAtoN), in the driver's
# channel order. Thumb_Opposition and Finger_Spread have none (0, 0): the library's effort there is always 0.
EFFORT_CONSTANTS = (
    (0.015, -1.543),
    (0.0, 0.0),
    (0.014, -0.07),
    (0.015, 0.282),
    (0.014, -0.026),
    (0.015, 0.336),
    (0.007, -0.073),
    (0.005, 0.081),
    (0.0, 0.0),
)
# robot_state_publisher's publish_frequency (ROS 2, its default): /tf of the moving joints at most this often (Hz)
TF_RATE = 20.0
# JTC's parameters a real controller node declares whatever the yaml says (joint_trajectory_controller_parameters.yaml,
# Jazzy), where the yaml gives none.
JTC_DECLARED = {
    "allow_partial_joints_goal": False,
    "allow_nonzero_velocity_at_trajectory_end": False,
    "action_monitor_rate": 20.0,
    "interpolation_method": "splines",
    "constraints.goal_time": JTC_DEFAULTS["goal_time"],
    "constraints.stopped_velocity_tolerance": JTC_DEFAULTS["stopped_velocity_tolerance"],
}


def flat(parameters: Mapping[str, Any], prefix: str = "") -> dict[str, Any]:
    """A yaml's nested ``ros__parameters`` as ROS 2's dotted names (``constraints.goal_time``)."""
    out: dict[str, Any] = {}
    for key, value in parameters.items():
        if isinstance(value, Mapping):
            out.update(flat(value, f"{prefix}{key}."))
        elif not (isinstance(value, list) and not value):  # an empty list has no parameter type
            out[f"{prefix}{key}"] = value
    return out


def node_with(rclpy: Any, name: str, parameters: Mapping[str, Any]) -> Any:
    """An rclpy node named ``name`` declaring ``parameters``, on simulated time (use_sim_time) whose /clock
    subscription is dropped: the simulation sets every node's time itself (node.py: why)."""
    from rclpy.parameter import Parameter

    overrides = [Parameter("use_sim_time", Parameter.Type.BOOL, True)]
    overrides += [Parameter(key, value=value) for key, value in parameters.items()]
    node = rclpy.create_node(name, parameter_overrides=overrides, automatically_declare_parameters_from_overrides=True)
    for subscription in list(node.subscriptions):
        if subscription.topic_name == "/clock":
            node.destroy_subscription(subscription)
    return node


def controller_parameters(kind: str, parameters: Mapping[str, Any], jtc_type: str) -> dict[str, Any]:
    """What a controller node declares: the yaml's parameters, and JTC's defaults for a JTC."""
    declared = flat(parameters)
    if kind == jtc_type:
        declared = {**JTC_DECLARED, **declared}
    return declared


def current_and_effort(channel: int, force: float) -> tuple[float, float]:
    """One channel's ``current`` (mA) and ``effort`` (N) for an actuator force (see ``currents_and_efforts``)."""
    forces = np.zeros(len(EFFORT_CONSTANTS))
    forces[channel] = force
    currents, efforts = currents_and_efforts(forces)
    return float(currents[channel]), float(efforts[channel])


_A, _B = np.array(EFFORT_CONSTANTS).T
_KNOWN = np.flatnonzero(_A)  # the channels the library has constants for
_AK, _BK = _A[_KNOWN], _B[_KNOWN]


def currents_and_efforts(forces: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """SCHUNK's ``current`` (mA) and ``effort`` (N) state interfaces of the nine channels for their actuator forces:
    the current as the library's convertNtomA would ask for it, (|force| - b) / a rounded half away from zero as
    std::round (and never below 0 mA), and the effort back through convertmAtoN, a * current + b, as the driver's
    read() does. An estimate: MuJoCo's force is the servo's, not a motor's. Channels without constants: current
    NaN, effort 0."""
    currents, efforts = np.full(len(_A), np.nan), np.zeros(len(_A))
    known = np.maximum(0.0, np.floor((np.abs(forces[_KNOWN]) - _BK) / _AK + 0.5))
    currents[_KNOWN], efforts[_KNOWN] = known, _AK * known + _BK
    return currents, efforts


def _quaternion(roll: float, pitch: float, yaw: float) -> np.ndarray:
    """(x, y, z, w) of URDF's rpy (fixed axes X, Y, Z)."""
    cr, sr, cp, sp = math.cos(roll / 2), math.sin(roll / 2), math.cos(pitch / 2), math.sin(pitch / 2)
    cy, sy = math.cos(yaw / 2), math.sin(yaw / 2)
    return np.array(
        [
            sr * cp * cy - cr * sp * sy,
            cr * sp * cy + sr * cp * sy,
            cr * cp * sy - sr * sp * cy,
            cr * cp * cy + sr * sp * sy,
        ]
    )


def _multiply(p: np.ndarray, q: np.ndarray) -> np.ndarray:
    """Row-wise Hamilton products of (x, y, z, w) quaternions."""
    px, py, pz, pw = p.T
    qx, qy, qz, qw = q.T
    return np.stack(
        [
            pw * qx + px * qw + py * qz - pz * qy,
            pw * qy - px * qz + py * qw + pz * qx,
            pw * qz + px * qy - py * qx + pz * qw,
            pw * qw - px * qx - py * qy - pz * qz,
        ],
        axis=1,
    )


class Kinematics:
    """The URDF's joints as robot_state_publisher reads them: fixed ones once (/tf_static), moving ones
    (revolute, continuous, prismatic) from joint positions (/tf)."""

    def __init__(self, urdf: str) -> None:
        robot = etree.fromstring(urdf.encode())
        self.fixed: list[tuple[str, str, np.ndarray, np.ndarray]] = []
        moving: list[tuple[str, str, str, np.ndarray, np.ndarray, np.ndarray, bool]] = []
        for joint in robot.iter("joint"):
            kind = joint.get("type")
            parent, child = joint.find("parent"), joint.find("child")
            if parent is None or child is None:
                continue
            origin = joint.find("origin")
            xyz = np.array([float(v) for v in (origin.get("xyz", "0 0 0") if origin is not None else "0 0 0").split()])
            rpy = [float(v) for v in (origin.get("rpy", "0 0 0") if origin is not None else "0 0 0").split()]
            frames = (parent.get("link"), child.get("link"))
            if kind == "fixed":
                self.fixed.append((*frames, xyz, _quaternion(*rpy)))
            elif kind in ("revolute", "continuous", "prismatic"):
                axis_tag = joint.find("axis")
                axis = np.array([float(v) for v in (axis_tag.get("xyz") if axis_tag is not None else "1 0 0").split()])
                axis = axis / np.linalg.norm(axis)
                moving.append((joint.get("name"), *frames, xyz, _quaternion(*rpy), axis, kind == "prismatic"))
        self.joints = [m[0] for m in moving]
        self.frames = [(m[1], m[2]) for m in moving]
        self._xyz = np.array([m[3] for m in moving]).reshape(-1, 3)
        self._rpy = np.array([m[4] for m in moving]).reshape(-1, 4)
        self._axis = np.array([m[5] for m in moving]).reshape(-1, 3)
        self._prismatic = np.array([m[6] for m in moving], dtype=bool)

    def moving(self, positions: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Translations (n, 3) and rotations (n, 4; x, y, z, w) of the moving joints at ``positions`` (their
        order: ``joints``)."""
        angle = np.where(self._prismatic, 0.0, positions)
        half = 0.5 * angle
        turn = np.concatenate([self._axis * np.sin(half)[:, None], np.cos(half)[:, None]], axis=1)
        rotation = _multiply(self._rpy, turn)
        shift = np.where(self._prismatic, positions, 0.0)[:, None] * self._axis
        # the prismatic shift is along the axis in the joint frame: rotate it by the origin's rotation
        translation = self._xyz + _rotate(self._rpy, shift)
        return translation, rotation


def _rotate(q: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Row-wise rotation of vectors ``v`` by (x, y, z, w) quaternions ``q``."""
    u, w = q[:, :3], q[:, 3:4]
    return v + 2.0 * np.cross(u, np.cross(u, v) + w * v)


def urdf_xacro(controllers: Path) -> Path:
    """The ROS 2 URDF beside a controllers file (``ros2/config/..`` -> ``ros2/urdf/<name>.urdf.xacro``; a folder's
    package is named after its robot, not the folder)."""
    found = sorted((controllers.parents[1] / "urdf").glob("*.urdf.xacro"))
    if len(found) != 1:
        raise SvhdescError(f"{controllers.parents[1] / 'urdf'}: expected one *.urdf.xacro, found {len(found)}")
    return found[0]


def description(xacro_file: Path, controllers: Path) -> str:
    """The variant's ROS 2 URDF, xacro-expanded as its launch file expands it (hardware ``mujoco``)."""
    import xacro

    document = xacro.process_file(str(xacro_file), mappings={"hardware": "mujoco", "controllers": str(controllers)})
    return document.toxml()


def system_joints(xacro_file: Path) -> list[str]:
    """The joints of the ``<ros2_control>`` system in its order (joint_state_broadcaster publishes them so)."""
    system = xacro_file.with_name(xacro_file.name.replace(".urdf.xacro", ".ros2_control.xacro"))
    tree = etree.parse(str(system))
    return [j.get("name") for r in tree.iter("ros2_control") for j in r.iter("joint")]


class StatePublisher:
    """robot_state_publisher's topics: /robot_description and /tf_static latched (transient local), /tf at most
    TF_RATE times a simulated second (ROS 2 robot_state_publisher's publish_frequency, 20 Hz by default: it
    throttles the joint_states it gets so), sent as bytes written into a serialized template (Prefilled)."""

    def __init__(self, node: Any, urdf: str, joint_names: Sequence[str]) -> None:
        from geometry_msgs.msg import TransformStamped
        from rclpy.qos import DurabilityPolicy, QoSProfile
        from rclpy.serialization import serialize_message
        from std_msgs.msg import String
        from tf2_msgs.msg import TFMessage

        latched = QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL)
        self.kinematics = Kinematics(urdf)
        where = {name: k for k, name in enumerate(joint_names)}
        known = [k for k, name in enumerate(self.kinematics.joints) if name in where]  # others get no transform
        self._rows = np.array(known, dtype=int)
        self._columns = np.array([where[self.kinematics.joints[k]] for k in known], dtype=int)
        node.create_publisher(String, "robot_description", latched).publish(String(data=urdf))
        static = TFMessage()
        for parent, child, xyz, quaternion in self.kinematics.fixed:
            static.transforms.append(_transform(TransformStamped, parent, child, xyz, quaternion))
        self._static = node.create_publisher(TFMessage, "/tf_static", latched)
        self._static_message = static
        self._tf = node.create_publisher(TFMessage, "/tf", 100)
        template = TFMessage()
        for j, k in enumerate(known):
            values = [Prefilled.marker(7 * j + i) for i in range(7)]
            transform = _transform(TransformStamped, *self.kinematics.frames[k], values[:3], values[3:])
            transform.header.stamp.sec, transform.header.stamp.nanosec = Prefilled.STAMP[0] + j, Prefilled.STAMP[1]
            template.transforms.append(transform)
        self._message = Prefilled(serialize_message(template), 7 * len(known), len(known))
        self._static_sent = False
        self._next = 0.0

    def publish(self, stamp: Any, at: float, positions: np.ndarray) -> None:
        """/tf of the moving joints at ``positions`` (joint_states' order) when due at ``at`` (simulated s);
        /tf_static once, stamped then."""
        if at < self._next - 1e-9:
            return
        self._next = max(self._next + 1.0 / TF_RATE, at)
        if not self._static_sent:
            for transform in self._static_message.transforms:
                transform.header.stamp = stamp
            self._static.publish(self._static_message)
            self._static_sent = True
        all_positions = np.zeros(len(self.kinematics.joints))
        all_positions[self._rows] = positions[self._columns]
        translation, rotation = self.kinematics.moving(all_positions)
        values = np.concatenate([translation[self._rows], rotation[self._rows]], axis=1).ravel()
        self._tf.publish(self._message.payload(values, stamp.sec, stamp.nanosec))


def _transform(kind: Any, parent: str, child: str, xyz: Sequence[float], quaternion: Sequence[float]) -> Any:
    transform = kind()
    transform.header.frame_id, transform.child_frame_id = parent, child
    v, q = transform.transform.translation, transform.transform.rotation
    v.x, v.y, v.z = (float(x) for x in xyz)
    q.x, q.y, q.z, q.w = (float(x) for x in quaternion)
    return transform


class Prefilled:
    """A message published as bytes: serialized once (rclpy's serialize_message) with marker values in its float64
    fields and its stamps; each publication writes the new values into a copy of those bytes at the markers'
    places. rclpy's per-message conversion of a nested message (every joint's interface names, every frame name) from
    Python to C is what this saves: /dynamic_joint_states that way cost the as-fast node a quarter of its rate."""

    STAMP = (1_357_924_680, 24_680)  # (sec, nanosec): stamps are found by these

    def __init__(self, serialized: bytes, doubles: int, stamps: int) -> None:
        data = bytearray(serialized)
        if data[:2] != b"\x00\x01":
            raise ValueError("not little-endian CDR")
        self._data = data
        self._doubles = [self._find(data, struct.pack("<d", self.marker(k))) for k in range(doubles)]
        sec, nanosec = self.STAMP
        self._stamps = [self._find(data, struct.pack("<iI", sec + j, nanosec)) for j in range(stamps)]
        # CDR aligns a float64 to 8 bytes from the payload's start (after the 4-byte encapsulation header)
        if any((offset - 4) % 8 for offset in self._doubles):
            raise ValueError("a float64 off CDR's alignment")
        self._view = np.ndarray(((len(data) - 4) // 8,), dtype="<f8", buffer=data, offset=4)
        self._index = np.array([(offset - 4) // 8 for offset in self._doubles], dtype=int)

    @staticmethod
    def marker(k: int) -> float:
        return math.ldexp(1.0 + k / 4096.0, 300)

    @staticmethod
    def _find(data: bytearray, pattern: bytes) -> int:
        if data.count(pattern) != 1:
            raise ValueError("a marker is not unique in the serialized message")
        return data.find(pattern)

    def payload(self, values: np.ndarray, sec: int, nanosec: int) -> bytes:
        """The message with ``values`` (the markers' order) and every stamp ``sec``.``nanosec``."""
        data = self._data
        self._view[self._index] = values
        for offset in self._stamps:
            struct.pack_into("<iI", data, offset, sec, nanosec)
        return bytes(data)


def joint_state_template(names: Sequence[str]) -> Prefilled:
    """joint_states as bytes (Prefilled): ``names``, then positions, velocities, efforts (3 n values) and the stamp."""
    from rclpy.serialization import serialize_message
    from sensor_msgs.msg import JointState

    n = len(names)
    markers = [Prefilled.marker(k) for k in range(3 * n)]
    message = JointState(name=list(names), position=markers[:n], velocity=markers[n : 2 * n], effort=markers[2 * n :])
    message.header.stamp.sec, message.header.stamp.nanosec = Prefilled.STAMP
    return Prefilled(serialize_message(message), 3 * n, 1)


def clock_template() -> Prefilled:
    """/clock (rosgraph_msgs/Clock) as bytes: its stamp only."""
    from rclpy.serialization import serialize_message
    from rosgraph_msgs.msg import Clock

    message = Clock()
    message.clock.sec, message.clock.nanosec = Prefilled.STAMP
    return Prefilled(serialize_message(message), 0, 1)
