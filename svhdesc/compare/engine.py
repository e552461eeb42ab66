"""The small interface every engine adapter implements, and the servo gains they share.

An adapter loads the generated model (MJCF for MuJoCo, URDF for the others), adds the fixed surface of
``experiment.Setup``, applies the inertia setting to the finger links, and then only steps: servo
targets in, joint positions / fingertip force / fingertip position out.
"""

from __future__ import annotations

import importlib
from abc import ABC, abstractmethod
from dataclasses import dataclass
from typing import Any

import numpy as np

from svhdesc.compare.experiment import Setup

TIMESTEP = 0.001  # s, the thesis' and the generated MJCF's step; every engine is asked for it


class EngineMissing(Exception):
    """The engine's Python package is not installed; the message says how to install it."""


@dataclass(frozen=True)
class Servo:
    """Position servo per actuated joint (``Setup.actuated`` order): tau = kp (q* - q) - kv qdot, |tau| <= limit.

    kp and the force limit are the model's; kv is what MuJoCo's ``dampratio="1"`` gives for the same
    inertia setting, so every engine that takes physical gains gets the same ones."""

    kp: np.ndarray
    kv: np.ndarray
    limit: np.ndarray


@dataclass(frozen=True)
class RunConfig:
    variant: str
    setup: Setup
    inertia: float | None  # diagonal inertia of every finger link [kg m^2]; None: the physical inertials
    finger_links: frozenset[str]
    servo: Servo
    timestep: float = TIMESTEP
    mass: float | None = None  # mass of every link in ``mass_links`` [kg]; None: the physical masses
    mass_links: frozenset[str] = frozenset()


class Engine(ABC):
    """One physics engine running the experiment. Construct, ``load``, then ``step`` repeatedly."""

    name: str = ""
    module: str = ""  # what must be importable
    install: str = ""  # how to get it
    distribution: str = ""  # the PyPI name, where it differs from the module

    @classmethod
    def require(cls) -> None:
        """Import the engine, or raise EngineMissing saying how to install it."""
        try:
            importlib.import_module(cls.module)
        except ImportError:
            raise EngineMissing(f"not installed ({cls.install})") from None

    @abstractmethod
    def load(self, config: RunConfig) -> None:
        """Build the world: model, surface, inertia, servos; the robot at its ``home`` keyframe."""

    @abstractmethod
    def step(self, targets: np.ndarray) -> None:
        """Advance one timestep with these servo targets (``Setup.actuated`` order)."""

    @abstractmethod
    def joint_positions(self) -> np.ndarray:
        """Positions of ``Setup.joints`` [rad]."""

    @abstractmethod
    def fingertip_force(self) -> float:
        """Normal force the surface exerts on the fingertip [N] (0 without contact)."""

    def fingertip_force_vector(self) -> np.ndarray:
        """Total force the surface exerts on the fingertip, world frame [N] (its z: the vertical component)."""
        raise NotImplementedError(f"{self.name} does not report the contact force vector")

    @abstractmethod
    def fingertip_position(self) -> np.ndarray:
        """World position of the fingertip link frame [m]."""

    def coupling_residual(self, setup: Setup) -> float:
        """Worst |q_coupled - f(q_channel)| over the couplings now [rad], from the engine's own joint positions."""
        residual = setup.coupling_residual(self.joint_positions())
        return float(residual.max()) if residual.size else 0.0

    @abstractmethod
    def settings(self) -> dict[str, Any]:
        """Solver and contact settings in force, to print beside the results."""

    @property
    @abstractmethod
    def timestep(self) -> float:
        """The step the engine actually takes [s]."""

    @classmethod
    def version(cls) -> str:
        """The installed distribution's version (what `pip install` put there)."""
        from importlib.metadata import PackageNotFoundError, version

        try:
            return version(cls.distribution or cls.module)
        except PackageNotFoundError:
            return "?"

    def close(self) -> None:  # noqa: B027 - optional hook
        """Free engine resources (a pybullet client, for example)."""
