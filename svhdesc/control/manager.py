"""ros_control's controller_manager on plain values: the loaded controllers, their states and
ControllerManager::switchController (noetic), or ros2_control's switch_controller (Jazzy, ``SWITCH_JAZZY``).

Strictness 0 means BEST_EFFORT; under STRICT an unknown name, starting a running controller or stopping a
stopped one fails the whole request (nothing changes); under BEST_EFFORT those entries are dropped and the rest
switch. Stopping a trajectory controller preempts its goal and holds the joints; joint_state_controller cannot be
switched (it is always on here).

Where the two managers differ (``SwitchSemantics``): noetic refuses a request that would leave a resource claimed
by two running controllers (RobotHW::checkForConflict) and one that starts and stops the same controller; Jazzy's
controller_manager.cpp restarts a controller named in both lists (can_controller_restart), and finds a claimed
command interface only when it activates, in the real-time loop: that controller stays inactive ("Resource conflict
for controller '...'. Command interface '...' is already claimed."), the others switch and the request answers ok.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

BASE_CLASS = "controller_interface::ControllerBase"
BEST_EFFORT, STRICT = 1, 2


@dataclass(frozen=True)
class SwitchSemantics:
    restarts: bool  # a controller both stopped and started is restarted (Jazzy), or the request refused (noetic)
    conflicts_refuse: bool  # a doubly claimed resource refuses the request (noetic) or skips the activation (Jazzy)


SWITCH_NOETIC = SwitchSemantics(restarts=False, conflicts_refuse=True)
SWITCH_JAZZY = SwitchSemantics(restarts=True, conflicts_refuse=False)


@dataclass
class Loaded:
    name: str
    type: str
    interface: str  # the hardware interface it claims from
    resources: list[str]
    running: bool
    controller: Any = None  # with starting()/stopping(); None: always on (joint_state_controller)
    started: bool = False  # ever started: a loaded, never-started controller is "initialized"

    def __post_init__(self) -> None:
        self.started = self.started or self.running

    @property
    def state(self) -> str:
        """ros_control noetic's ControllerState.state: running, stopped, or initialized (never started)."""
        if self.running:
            return "running"
        return "stopped" if self.started else "initialized"


@dataclass(frozen=True)
class ControllerInfo:
    """One entry of list_controllers."""

    name: str
    type: str
    state: str
    interface: str
    resources: list[str]


class SwitchCore:
    def __init__(
        self, controllers: list[Loaded], log: Callable[[str, str], None], semantics: SwitchSemantics = SWITCH_NOETIC
    ) -> None:
        """``log(level, text)``: level 'warn' or 'error'."""
        self.controllers = {c.name: c for c in controllers}
        self._log = log
        self.semantics = semantics

    def listed(self) -> list[ControllerInfo]:
        return [
            ControllerInfo(c.name, c.type, c.state, c.interface, list(c.resources)) for c in self.controllers.values()
        ]

    def types(self) -> list[str]:
        return sorted({c.type for c in self.controllers.values()})

    def switch(self, start: list[str], stop: list[str], strictness: int) -> bool | str:
        """Start and stop controllers at once (simulation thread). True, or why not."""
        if strictness == 0:
            self._log("warn", "Controller Manager: no strictness given; defaulting to BEST_EFFORT")
            strictness = BEST_EFFORT
        strict = strictness == STRICT
        both = sorted(set(start) & set(stop))
        if both and not self.semantics.restarts:  # ros_control 0.20 refuses this at any strictness
            return self._refuse(f"{both} would be started and stopped at once")
        stopping = self._select(stop, lambda c: c.running, "stop", "not running", strict)
        if isinstance(stopping, str):
            return self._refuse(stopping)
        starting = self._select(start, lambda c: not c.running or c in stopping, "start", "already running", strict)
        if isinstance(starting, str):
            return self._refuse(starting)
        if self.semantics.conflicts_refuse:
            conflict = self._conflict(stopping, starting)
            if conflict is not None:
                return self._refuse(conflict)
        for loaded in stopping:
            self.stop(loaded)
        for loaded in starting:
            claimed = self._claimed_by_others(loaded)
            if claimed is not None:  # Jazzy: found as the real-time loop activates; the rest of the switch stands
                self._log(
                    "error",
                    f"Resource conflict for controller '{loaded.name}'. Command interface '{claimed}' is "
                    "already claimed.",
                )
                continue
            loaded.controller.starting()
            loaded.running = loaded.started = True
        return True

    def stop(self, loaded: Loaded) -> None:
        loaded.controller.stopping()
        loaded.running = False

    def fail(self, name: str) -> None:
        """ros2_control: a controller whose update returned ERROR is deactivated by the controller manager."""
        loaded = self.controllers[name]
        if loaded.running:
            self._log("error", f"Deactivating following controllers as their update resulted in an error :\n\t- {name}")
            self.stop(loaded)

    def _claimed_by_others(self, loaded: Loaded) -> str | None:
        for other in self.controllers.values():
            if other.running and other is not loaded:
                for resource in loaded.resources:
                    if resource in other.resources:
                        return resource
        return None

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
