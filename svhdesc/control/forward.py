"""forward_command_controller's position group on plain values: ros2_controllers' (Jazzy)
``position_controllers/JointGroupPositionController`` and ros_controllers' (noetic) controller of the same name.

One command is one value per joint, in the controller's joint order, written to the joints' position servos. Where
the two differ (``ForwardSemantics``):

- Jazzy (forward_controllers_base.cpp): activating clears the command buffer and writes nothing, so the joints keep
  the command they had until the first message; a command of the wrong length makes ``update`` log "command size (N)
  does not match number of interfaces (M)" and return ERROR, and the controller_manager then deactivates the
  controller ("Deactivating following controllers as their update resulted in an error"): ``command`` returns that
  error for the adapter's manager to act on.
- noetic (forward_command_controller.h, position_controllers): starting commands the current positions; a command
  of the wrong length is refused with "Dimension of command (N) does not match number of joints (M)! Not
  executing!" and the controller runs on.

Both: non-finite values drop the message with a warning (ros2_controllers 5.4's subscriber check; Jazzy's 4.x and
noetic pass them to the hardware), values outside a joint's range are clamped to it as its servo's ctrlrange does.
No transport, no simulator import: ``Servos`` is what the controller needs of the simulation.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Protocol


class Servos(Protocol):
    """The position servos a forward controller writes (svhdesc.sim.Simulation is one)."""

    def set_targets(self, targets: Mapping[str, float]) -> None: ...
    def hold(self, names: Sequence[str]) -> None: ...


@dataclass(frozen=True)
class ForwardSemantics:
    holds_on_start: bool  # noetic's starting(): command the current positions
    wrong_size_fails: bool  # Jazzy: update() returns ERROR, the controller_manager deactivates the controller


NOETIC_FORWARD = ForwardSemantics(holds_on_start=True, wrong_size_fails=False)
JAZZY_FORWARD = ForwardSemantics(holds_on_start=False, wrong_size_fails=True)


@dataclass(frozen=True)
class CommandError:
    """A command the controller could not execute; ``fails`` when the controller must be deactivated."""

    text: str
    fails: bool


class ForwardCommandCore:
    def __init__(
        self,
        name: str,
        joints: Sequence[str],
        servos: Servos,
        log: Callable[[str, str], None],
        semantics: ForwardSemantics,
        running: bool = False,
    ) -> None:
        """``log(level, text)``: level 'warn' or 'error'. ``joints``: the simulation's names, in command order."""
        self.name = name
        self.joints = list(joints)
        self.semantics = semantics
        self.running = running
        self._servos = servos
        self._log = log
        self.commands = 0  # commands executed since the controller last started

    def starting(self) -> None:
        if self.semantics.holds_on_start:
            self._servos.hold(self.joints)
        self.commands = 0
        self.running = True

    def stopping(self) -> None:
        """The joints keep their last command (ros2_control: a deactivated controller writes nothing)."""
        self.running = False

    def update(self) -> None:
        """Commands act when they arrive (the simulation thread runs them before the next physics step)."""

    def command(self, values: Sequence[float]) -> CommandError | None:
        """One Float64MultiArray's data (simulation thread); None when the joints took it."""
        if not self.running:
            return None  # the real subscription buffers it and activation clears the buffer
        values = list(values)
        if len(values) != len(self.joints):
            if self.semantics.wrong_size_fails:
                text = f"command size ({len(values)}) does not match number of interfaces ({len(self.joints)})"
            else:
                text = (
                    f"Dimension of command ({len(values)}) does not match number of joints ({len(self.joints)})! "
                    "Not executing!"
                )
            self._log("error", f"{self.name}: {text}")
            return CommandError(text, self.semantics.wrong_size_fails)
        if not all(math.isfinite(v) for v in values):
            text = "Non-finite value received. Dropping message"
            self._log("warn", f"{self.name}: {text}")
            return CommandError(text, False)
        self._servos.set_targets(dict(zip(self.joints, values)))
        self.commands += 1
        return None
