"""The world the model lives in: solver options and the scene's floor, from their settings sections into the IR."""

from __future__ import annotations

from dataclasses import replace

from svhdesc.compiler.assets import Assets
from svhdesc.core.settings.schema import Scene, Simulation
from svhdesc.ir import Ground, Physics, Robot


def add_world(robot: Robot, assets: Assets, section: tuple[Simulation, Scene]) -> Robot:
    simulation, scene = section
    physics = Physics(
        timestep=simulation.timestep,
        noslip_iterations=simulation.noslip_iterations,
        coupling_solref=tuple(simulation.coupling_solref),
        coupling_solimp=tuple(simulation.coupling_solimp),
        gravity_compensation=simulation.gravity_compensation,
        cone=simulation.cone,
    )
    return replace(robot, physics=physics, ground=Ground(scene.floor_z, scene.pedestal_radius))
