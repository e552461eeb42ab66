"""ros_control's controller_manager on plain values: the loaded controllers, their states and
ControllerManager::switchController (noetic).

Strictness 0 means BEST_EFFORT; under STRICT an unknown name, starting a running controller, stopping a
stopped one or a resource claimed twice fails the whole request (nothing changes); under BEST_EFFORT
those entries are dropped and the rest switch. Stopping a trajectory controller preempts its goal and
holds the joints; joint_state_controller cannot be switched (it is always on here).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

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


@dataclass(frozen=True)
class ControllerInfo:
    """One entry of list_controllers."""

    name: str
    type: str
    state: str
    interface: str
    resources: list[str]


class SwitchCore:
    def __init__(self, controllers: list[Loaded], log: Callable[[str, str], None]) -> None:
        """``log(level, text)``: level 'warn' or 'error'."""
        self.controllers = {c.name: c for c in controllers}
        self._log = log

    def listed(self) -> list[ControllerInfo]:
        return [
            ControllerInfo(c.name, c.type, "running" if c.running else "stopped", c.interface, list(c.resources))
            for c in self.controllers.values()
        ]

    def types(self) -> list[str]:
        return sorted({c.type for c in self.controllers.values()})

    def switch(self, start: list[str], stop: list[str], strictness: int) -> bool | str:
        """Start and stop controllers at once (simulation thread). True, or why not."""
        if strictness == 0:
            self._log("warn", "Controller Manager: no strictness given; defaulting to BEST_EFFORT")
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
        self._log("error", f"Could not switch controllers: {why}")
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
                self._log("warn", why)
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
