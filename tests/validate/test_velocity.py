"""validate on a continuous joint driven by a velocity servo (tests/support.py ``wheeled``): ``velocity_tracking``
holds it to the velocities it is commanded, ``gravity_hold`` leaves it out (it holds a velocity, not a position)."""

from __future__ import annotations

from pathlib import Path

import pytest

from svhdesc.validate.hold import check_gravity_hold
from svhdesc.validate.options import Options
from svhdesc.validate.pair import ModelPair, load_pair
from svhdesc.validate.velocity import check_velocity_tracking
from tests.support import wheeled


@pytest.fixture(scope="module")
def folder() -> Path:
    return wheeled()


def _pair(folder: Path) -> ModelPair:
    return load_pair(folder / "wheeled.urdf", folder / "wheeled.xml")


def test_velocity_tracking_holds_the_servo_to_its_command(folder: Path) -> None:
    """The wheel turns at +-1.5 rad/s as commanded; with its kv a thousand times lower it lags and fails, naming it
    (the seeded fault); a model without velocity servos skips the check."""
    (check,) = check_velocity_tracking(_pair(folder), Options())
    assert check.status == "pass" and check.data["relative_error"]["wheel"] < 0.01, check.detail
    weak = _pair(folder)
    wheel = weak.model.actuator("wheel").id
    weak.model.actuator_gainprm[wheel, 0] /= 1000
    weak.model.actuator_biasprm[wheel, 2] /= 1000
    (check,) = check_velocity_tracking(weak, Options())
    assert check.status == "fail" and "wheel off by" in check.detail, check.detail
    weak.model.actuator_biasprm[wheel, 1] = -1.0  # a position servo now
    assert check_velocity_tracking(weak, Options())[0].status == "skipped"


def test_gravity_hold_leaves_a_velocity_servo_out(folder: Path) -> None:
    """The arm tilted at home over a wheel whose drive does not carry gravity, gravity sideways: the wheel creeps
    (its servo holds a velocity, 0: a damper), the elbow holds, and the check passes on the elbow (seeded fault:
    hold_keyframe counting the wheel: it fails, naming it)."""
    pair = _pair(folder)
    model = pair.model
    home = model.key("home")
    home.qpos[model.joint("elbow").qposadr[0]] = home.ctrl[model.actuator("elbow").id] = 1.0
    model.jnt_actgravcomp[model.joint("wheel").id] = 0
    model.opt.gravity[:] = (0.0, 9.81, 0.0)
    (check,) = check_gravity_hold(pair, Options())
    assert check.status == "pass" and check.data["keyframes"]["home"]["joint"] == "elbow", check.detail
