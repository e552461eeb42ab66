"""The simulation on a velocity servo (joints.NAME.servo: velocity; tests/support.py ``wheeled``): its target is a
velocity, held at 0; it takes no position, trajectory or position gains."""

from __future__ import annotations

import pytest

from svhdesc.errors import SvhdescError
from svhdesc.sim import Simulation
from tests.support import wheeled


def test_a_velocity_servo_takes_velocities_and_holds_still() -> None:
    """Seeded faults: Simulation.hold writing the wheel's position as its target -> after the teleport to 7 rad the
    wheel spins at its limit instead of standing; follow without _position_servo -> the trajectory is taken."""
    sim = Simulation(str(wheeled()))
    assert sim.info.velocity_joints == ("wheel",) and sim.info.arm_joints == ("elbow",)
    assert sim.limits("wheel") == (-3.0, 3.0) and sim.targets()["wheel"] == 0.0
    wheel = sim.model.joint("wheel").dofadr[0]
    sim.set_target("wheel", 1.5)
    sim.run(0.5, realtime=False)
    assert sim.data.qvel[wheel] == pytest.approx(1.5, abs=0.01)
    sim.set_joint_position("wheel", 7.0)  # any angle: a continuous joint
    sim.hold(["wheel"])
    sim.run(0.5, realtime=False)
    assert sim.data.qpos[sim.model.joint("wheel").qposadr[0]] == pytest.approx(7.0, abs=1e-3)
    assert abs(sim.data.qvel[wheel]) < 1e-3
    for call in (lambda: sim.follow(["wheel"], []), lambda: sim.set_gains("wheel", 1.0, 1.0)):
        with pytest.raises(SvhdescError, match="'wheel' is on a velocity servo"):
            call()
