"""SCHUNK's hardware interface as a ROS 2 client sees it (schunk_svh_driver's SystemInterface): ``/svh/initialized``
(std_msgs/Bool, true once the hand is ready; here once the start's settling is done, which stands for the homing) and
the state interfaces ``position``, ``velocity``, ``effort``, ``current`` of each channel through
joint_state_broadcaster's ``/dynamic_joint_states`` (control_msgs/DynamicJointState)."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
from lxml import etree

from svhdesc.model import ros2_joint_name
from svhdesc.ros2.graph import Prefilled, currents_and_efforts
from svhdesc.sim import Simulation

SETTLE_SPEED = 0.01  # rad/s: every channel slower than this ends the start's settling
SETTLE_LONGEST = 1.0  # simulated s: the settling ends by then in any case
CHANNEL_INTERFACES = ("position", "velocity", "effort", "current")  # SystemInterface::export_state_interfaces
JOINT = ("position", "velocity")  # a joint the generated system declares nothing for


def state_interfaces(xacro_file: Path) -> dict[str, list[str]]:
    """Each ros2_control joint's state interfaces, as the generated system declares them."""
    system = xacro_file.with_name(xacro_file.name.replace(".urdf.xacro", ".ros2_control.xacro"))
    tree = etree.parse(str(system))
    return {
        j.get("name"): [i.get("name") for i in j.iter("state_interface")]
        for r in tree.iter("ros2_control")
        for j in r.iter("joint")
    }


class HardwareState:
    def __init__(
        self, broadcaster: Any, svh: Any | None, sim: Simulation, names: Sequence[str], xacro_file: Path
    ) -> None:
        """``names``: joint_states' joints (ROS 2 names, the system's order)."""
        from control_msgs.msg import DynamicJointState, InterfaceValue
        from rclpy.qos import DurabilityPolicy, QoSProfile
        from rclpy.serialization import serialize_message
        from std_msgs.msg import Bool

        self._sim = sim
        self._channels = [ros2_joint_name(c) for c in sim.info.hand_channels]
        self._actuators = np.array([sim.actuator(c) for c in sim.info.hand_channels], dtype=int)
        self._channel_dofs = np.array([sim.model.joint(c).dofadr[0] for c in sim.info.hand_channels], dtype=int)
        declared = state_interfaces(xacro_file)
        self._message = DynamicJointState(joint_names=list(names))
        self._channel_rows = np.array([list(names).index(c) for c in self._channels], dtype=int)
        self._table = np.zeros((len(names), len(CHANNEL_INTERFACES)))  # rows: joints; columns: CHANNEL_INTERFACES
        self._rows: list[tuple[Any, list[int]]] = []  # (InterfaceValue, its interfaces' columns in the table)
        for name in names:
            interfaces = list(CHANNEL_INTERFACES) if name in self._channels else declared.get(name, list(JOINT))
            interfaces = [i for i in interfaces if i in CHANNEL_INTERFACES]
            value = InterfaceValue(interface_names=interfaces, values=[0.0] * len(interfaces))
            self._message.interface_values.append(value)
            self._rows.append((value, [CHANNEL_INTERFACES.index(i) for i in interfaces if i in CHANNEL_INTERFACES]))
        self._flat = np.array(
            [row * len(CHANNEL_INTERFACES) + c for row, (_, columns) in enumerate(self._rows) for c in columns]
        )
        for k, value in enumerate(self._message.interface_values):  # the template: markers where the values go
            first = sum(len(v.interface_names) for v in self._message.interface_values[:k])
            value.values = [Prefilled.marker(first + i) for i in range(len(value.interface_names))]
        self._message.header.stamp.sec, self._message.header.stamp.nanosec = Prefilled.STAMP
        self._bytes = Prefilled(serialize_message(self._message), len(self._flat), 1)
        self._dynamic = broadcaster.create_publisher(DynamicJointState, "dynamic_joint_states", 10)
        latched = QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL)
        self._initialized = None if svh is None else svh.create_publisher(Bool, "svh/initialized", latched)
        self._Bool = Bool
        self.initialized = svh is None

    def settle(self) -> None:
        """The simulation thread, every update until done: /svh/initialized true once the channels are still."""
        if self.initialized:
            return
        speeds = np.abs(self._sim.data.qvel[self._channel_dofs])
        if self._sim.time >= SETTLE_LONGEST or (self._sim.time > 0.0 and float(speeds.max()) < SETTLE_SPEED):
            self.initialized = True
            assert self._initialized is not None
            self._initialized.publish(self._Bool(data=True))

    def read(self) -> np.ndarray:
        """The simulation thread: the channels' actuator forces now."""
        return self._sim.data.actuator_force[self._actuators].copy()

    def publish(
        self, stamp: Any, positions: np.ndarray, velocities: np.ndarray, efforts: np.ndarray, forces: np.ndarray
    ) -> None:
        """/dynamic_joint_states (the Outbox's thread), as bytes: the values written into the serialized template."""
        table = self._table
        table[:, 0], table[:, 1], table[:, 2], table[:, 3] = positions, velocities, efforts, 0.0
        if len(self._channel_rows):  # SCHUNK's nine channels (a robot without the hand has none)
            currents, channel_efforts = currents_and_efforts(forces)
            table[self._channel_rows, 2], table[self._channel_rows, 3] = channel_efforts, currents
        self._dynamic.publish(self._bytes.payload(table.ravel()[self._flat], stamp.sec, stamp.nanosec))
