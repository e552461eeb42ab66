"""``/controller_manager``: list_controllers, list_controller_types and switch_controller as
ros_control's controller_manager serves them, over the controllers the real drivers load.

Switching follows ControllerManager::switchController (noetic): strictness 0 means BEST_EFFORT; under
STRICT an unknown name, starting a running controller, stopping a stopped one or a resource claimed
twice fails the whole request (ok = False, nothing changes); under BEST_EFFORT those entries are
dropped and the rest switch. Stopping a trajectory controller preempts its goal and holds the joints;
joint_state_controller cannot be switched (it is always on here).
"""

from __future__ import annotations

from collections import deque
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from svhdesc.ros.controller import on_sim_thread

BASE_CLASS = "controller_interface::ControllerBase"
BEST_EFFORT, STRICT = 1, 2


@dataclass
class Loaded:
    name: str
    type: str
    interface: str  # the hardware interface it claims from
    resources: list[str]
    running: bool
    controller: Any = None  # with starting()/stopping(); None: always on (joint_state_controller)


class ControllerManager:
    def __init__(self, controllers: list[Loaded], queue: deque) -> None:
        import rospy

        from svhdesc.ros.messages import controller_manager_msgs

        self._rospy = rospy
        self._msgs = controller_manager_msgs()
        self.controllers = {c.name: c for c in controllers}
        self._queue = queue
        base = "controller_manager"
        self._services = [
            rospy.Service(f"{base}/list_controllers", self._msgs.ListControllers, self._on_list),
            rospy.Service(f"{base}/list_controller_types", self._msgs.ListControllerTypes, self._on_types),
            rospy.Service(f"{base}/switch_controller", self._msgs.SwitchController, self._on_switch),
        ]

    def _on_list(self, _: Any) -> Any:
        msgs = self._msgs
        return msgs.ListControllersResponse(
            controller=[
                msgs.ControllerState(
                    name=c.name,
                    state="running" if c.running else "stopped",
                    type=c.type,
                    claimed_resources=[msgs.HardwareInterfaceResources(c.interface, list(c.resources))],
                )
                for c in self.controllers.values()
            ]
        )

    def _on_types(self, _: Any) -> Any:
        types = sorted({c.type for c in self.controllers.values()})
        return self._msgs.ListControllerTypesResponse(types=types, base_classes=[BASE_CLASS] * len(types))

    def _on_switch(self, request: Any) -> Any:
        answer = on_sim_thread(
            self._queue,
            lambda: self.switch(list(request.start_controllers), list(request.stop_controllers), request.strictness),
        )
        return self._msgs.SwitchControllerResponse(ok=answer is True)

    def switch(self, start: list[str], stop: list[str], strictness: int) -> bool | str:
        """Start and stop controllers at once (simulation thread). True, or why not."""
        if strictness == 0:
            self._rospy.logwarn("Controller Manager: no strictness given; defaulting to BEST_EFFORT")
            strictness = BEST_EFFORT
        strict = strictness == STRICT
        stopping = self._select(stop, lambda c: c.running, "stop", "not running", strict)
        if isinstance(stopping, str):
            return self._refuse(stopping)
        starting = self._select(start, lambda c: not c.running or c in stopping, "start", "already running", strict)
        if isinstance(starting, str):
            return self._refuse(starting)
        conflict = self._conflict(stopping, starting)
        if conflict is not None:
            return self._refuse(conflict)
        for loaded in stopping:
            loaded.controller.stopping()
            loaded.running = False
        for loaded in starting:
            loaded.controller.starting()
            loaded.running = True
        return True

    def _refuse(self, why: str) -> str:
        self._rospy.logerr(f"Could not switch controllers: {why}")
        return why

    def _select(
        self, names: list[str], usable: Callable[[Loaded], bool], verb: str, state: str, strict: bool
    ) -> list[Loaded] | str:
        """The switchable controllers among `names`: unknown, always-on or unusable ones are dropped with a
        warning, or under STRICT the first of them is the refusal returned."""
        chosen: list[Loaded] = []
        for name in names:
            loaded = self.controllers.get(name)
            if loaded is None or loaded.controller is None or not usable(loaded):
                why = f"cannot {verb} {name!r}: it is {'not loaded' if loaded is None else state}"
                if strict:
                    return why
                self._rospy.logwarn(why)
                continue
            chosen.append(loaded)
        return chosen

    def _conflict(self, stopping: list[Loaded], starting: list[Loaded]) -> str | None:
        """RobotHW::checkForConflict: no resource may be claimed by two running controllers."""
        after = [c for c in self.controllers.values() if (c.running and c not in stopping) or c in starting]
        claimed: dict[str, str] = {}
        for controller in after:
            for resource in controller.resources:
                if resource in claimed:
                    return f"{controller.name} and {claimed[resource]} would both claim {resource}"
                claimed[resource] = controller.name
        return None
