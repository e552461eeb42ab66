"""ros_controllers' ``position_controllers/JointGroupPositionController`` over ROS 1: ``<controller>/command``,
std_msgs/Float64MultiArray, one position per joint in the controller's order (a subscriber of queue size 1, as the
real controller's). The semantics are svhdesc.control.forward's with ``NOETIC_FORWARD``: starting commands the
current positions; a command of the wrong length is refused with the real controller's error and it runs on.
"""

from __future__ import annotations

from collections import deque
from collections.abc import Sequence
from typing import Any

from svhdesc.control.forward import NOETIC_FORWARD, ForwardCommandCore, Servos
from svhdesc.control.trajectory import ForwardsToCore
from svhdesc.control.work import Latest


class ForwardController(ForwardsToCore):
    def __init__(self, name: str, joints: Sequence[str], servos: Servos, queue: deque) -> None:
        """``joints``: the simulation's names, in the controller's order; commands queued for the simulation thread."""
        import rospy
        from std_msgs.msg import Float64MultiArray

        self.name = name
        self._rospy = rospy
        self.core = ForwardCommandCore(name, joints, servos, self._log, NOETIC_FORWARD)
        self._command = rospy.Subscriber(
            f"{name}/command", Float64MultiArray, Latest(queue, self.on_command), queue_size=1
        )

    def _log(self, level: str, text: str) -> None:
        (self._rospy.logerr if level == "error" else self._rospy.logwarn)(text)

    def on_command(self, message: Any) -> None:
        """The simulation thread."""
        self.core.command(message.data)
