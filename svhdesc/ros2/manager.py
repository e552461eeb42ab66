"""``/controller_manager/list_controllers`` and ``switch_controller`` over ROS 2 (controller_manager_msgs, Jazzy),
as ros2_control's controller_manager serves them; the switching is svhdesc.control.manager's."""

from __future__ import annotations

from collections import deque
from collections.abc import Callable
from typing import Any

from svhdesc.control.manager import SWITCH_JAZZY, Loaded, SwitchCore, SwitchSemantics
from svhdesc.control.work import on_sim_thread
from svhdesc.ros2.system import log_at

__all__ = ["ControllerManager", "Loaded", "ros2_state"]


def ros2_state(loaded: Loaded) -> str:
    """ros2_control's lifecycle state of a loaded and configured controller: active or inactive."""
    return "active" if loaded.running else "inactive"


class ControllerManager:
    def __init__(
        self,
        node: Any,
        controllers: list[Loaded],
        interfaces: dict[str, tuple[list[str], list[str]]],
        queue: deque,
        semantics: SwitchSemantics = SWITCH_JAZZY,
        callback_group: Any = None,
    ) -> None:
        """``interfaces``: each controller's (command, state) interfaces, ``<ROS 2 joint>/<interface>``."""
        from controller_manager_msgs.msg import ControllerState
        from controller_manager_msgs.srv import ListControllers, SwitchController

        self._node = node
        self._ControllerState = ControllerState
        self.core = SwitchCore(controllers, self._log, semantics)
        self._interfaces = interfaces
        self._queue = queue
        base = "controller_manager"
        self._services = [
            node.create_service(
                ListControllers, f"{base}/list_controllers", self._on_list, callback_group=callback_group
            ),
            node.create_service(
                SwitchController, f"{base}/switch_controller", self._on_switch, callback_group=callback_group
            ),
        ]

    def _log(self, level: str, text: str) -> None:
        log_at(self._node.get_logger(), level, text)

    def _on_list(self, _: Any, response: Any) -> Any:
        for loaded in list(self.core.controllers.values()):
            command, state = self._interfaces.get(loaded.name, ([], []))
            response.controller.append(
                self._ControllerState(
                    name=loaded.name,
                    state=ros2_state(loaded),
                    type=loaded.type,
                    claimed_interfaces=list(command) if loaded.running else [],
                    required_command_interfaces=list(command),
                    required_state_interfaces=list(state),
                )
            )
        return response

    def _on_switch(self, request: Any, response: Any) -> Any:
        """activate/deactivate (and the deprecated start/stop lists, merged), answered on the simulation thread."""
        start = list(request.activate_controllers) + list(request.start_controllers)
        stop = list(request.deactivate_controllers) + list(request.stop_controllers)
        work: Callable[[], bool | str] = lambda: self.core.switch(start, stop, int(request.strictness))  # noqa: E731
        response.ok = on_sim_thread(self._queue, work) is True
        return response
