"""``/controller_manager``: list_controllers, list_controller_types and switch_controller over ROS 1, as
ros_control's controller_manager serves them; the semantics are svhdesc.control.manager's."""

from __future__ import annotations

from collections import deque
from typing import Any

from svhdesc.control.manager import BASE_CLASS, Loaded, SwitchCore
from svhdesc.control.work import on_sim_thread

__all__ = ["ControllerManager", "Loaded"]


class ControllerManager:
    def __init__(self, controllers: list[Loaded], queue: deque) -> None:
        import rospy

        from svhdesc.ros1.messages import controller_manager_msgs

        self._rospy = rospy
        self._msgs = controller_manager_msgs()
        self.core = SwitchCore(controllers, self._log)
        self.controllers = self.core.controllers
        self._queue = queue
        base = "controller_manager"
        self._services = [
            rospy.Service(f"{base}/list_controllers", self._msgs.ListControllers, self._on_list),
            rospy.Service(f"{base}/list_controller_types", self._msgs.ListControllerTypes, self._on_types),
            rospy.Service(f"{base}/switch_controller", self._msgs.SwitchController, self._on_switch),
        ]

    def _log(self, level: str, text: str) -> None:
        (self._rospy.logerr if level == "error" else self._rospy.logwarn)(text)

    def _on_list(self, _: Any) -> Any:
        msgs = self._msgs
        return msgs.ListControllersResponse(
            controller=[
                msgs.ControllerState(
                    name=c.name,
                    state=c.state,
                    type=c.type,
                    claimed_resources=[msgs.HardwareInterfaceResources(c.interface, list(c.resources))],
                )
                for c in self.core.listed()
            ]
        )

    def _on_types(self, _: Any) -> Any:
        types = self.core.types()
        return self._msgs.ListControllerTypesResponse(types=types, base_classes=[BASE_CLASS] * len(types))

    def _on_switch(self, request: Any) -> Any:
        answer = on_sim_thread(
            self._queue,
            lambda: self.core.switch(
                list(request.start_controllers), list(request.stop_controllers), request.strictness
            ),
        )
        return self._msgs.SwitchControllerResponse(ok=answer is True)

    def switch(self, start: list[str], stop: list[str], strictness: int) -> bool | str:
        return self.core.switch(start, stop, strictness)
