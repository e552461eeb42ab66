"""``position_controllers/JointGroupPositionController`` over ROS 2 (ros2_controllers' forward_command_controller):
``<controller>/commands``, std_msgs/msg/Float64MultiArray, one position per joint in the controller's joint order,
subscribed with the system-default QoS as the real controller subscribes. The semantics are
svhdesc.control.forward's with ``JAZZY_FORWARD``; a command the core fails (wrong length) deactivates the controller
through the controller manager, as ros2_control's does after an update returns ERROR.
"""

from __future__ import annotations

from collections import deque
from collections.abc import Callable, Sequence
from typing import Any

from svhdesc.control.forward import JAZZY_FORWARD, ForwardCommandCore, Servos
from svhdesc.control.trajectory import ForwardsToCore
from svhdesc.control.work import Latest
from svhdesc.ros2.system import log_at


class ForwardController(ForwardsToCore):
    def __init__(
        self, node: Any, name: str, joints: Sequence[str], servos: Servos, queue: deque, callback_group: Any = None
    ) -> None:
        """``joints``: the simulation's names, in the controller's order. Commands are queued for the simulation
        thread (``queue``)."""
        from rclpy.qos import qos_profile_system_default
        from std_msgs.msg import Float64MultiArray

        self.name = name
        self._node = node
        self.core = ForwardCommandCore(name, joints, servos, self._log, JAZZY_FORWARD)
        self.on_failure: Callable[[str], None] = lambda _: None  # the controller manager's deactivation
        self._subscription = node.create_subscription(
            Float64MultiArray,
            f"{name}/commands",  # relative to the node: ~/commands of a controller node named <name>
            Latest(queue, self.on_command),
            qos_profile_system_default,
            callback_group=callback_group,
        )

    def _log(self, level: str, text: str) -> None:
        log_at(self._node.get_logger(), level, text)

    def on_command(self, message: Any) -> None:
        """The simulation thread."""
        error = self.core.command(message.data)
        if error is not None and error.fails:
            self.on_failure(self.name)
