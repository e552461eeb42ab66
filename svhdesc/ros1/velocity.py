"""ur_robot_driver's ``joint_group_vel_controller`` (velocity_controllers/JointGroupVelocityController),
loaded stopped: once switched on, ``command`` (std_msgs/Float64MultiArray, one velocity per joint in the
controller's order) sets the joints' velocities until the next command; a command of the wrong size is
refused with a logged reason, as the controller does. Starting and stopping command zero velocity.

The arm's actuators are position servos, so the commanded velocity is integrated into their targets every
control period.
"""

from __future__ import annotations

import math
from collections import deque
from collections.abc import Sequence
from typing import Any

import numpy as np

from svhdesc.control.work import Latest
from svhdesc.sim import Simulation


class VelocityGroupController:
    def __init__(self, name: str, joints: Sequence[str], sim: Simulation, queue: deque, running: bool = False) -> None:
        import rospy
        from std_msgs.msg import Float64MultiArray

        self.name = name
        self.joints = list(joints)
        self.running = running
        self._sim = sim
        self._rospy = rospy
        self._velocity = np.zeros(len(self.joints))
        self._targets = np.zeros(len(self.joints))
        self._last = sim.time
        self._limits = [sim.limits(j) for j in self.joints]
        self._command = rospy.Subscriber(
            f"{name}/command", Float64MultiArray, Latest(queue, self.on_command), queue_size=1
        )

    def on_command(self, msg: Any) -> None:
        values = list(msg.data)
        if not self.running:
            return
        if len(values) != len(self.joints) or not all(math.isfinite(v) for v in values):
            self._rospy.logwarn(
                f"{self.name}/command: {len(values)} values (or not finite) for {len(self.joints)} joints: ignored"
            )
            return
        self._velocity = np.array(values)

    def starting(self) -> None:
        self._sim.hold(self.joints)
        self._targets = np.array([self._sim.targets()[j] for j in self.joints])
        self._velocity[:] = 0.0
        self._last = self._sim.time
        self.running = True

    def stopping(self) -> None:
        self._velocity[:] = 0.0
        self._sim.hold(self.joints)
        self.running = False

    def update(self) -> None:
        now = self._sim.time
        step, self._last = now - self._last, now
        if not self.running or not self._velocity.any():
            return
        self._targets = self._targets + self._velocity * step
        for k, (joint, (low, high)) in enumerate(zip(self.joints, self._limits)):
            self._targets[k] = min(max(self._targets[k], low), high)
            self._sim.set_target(joint, float(self._targets[k]))
