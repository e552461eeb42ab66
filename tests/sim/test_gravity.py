"""The servos hold what they are told: gravity compensation through each joint's actuator, within its effort."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest
from lxml import etree

import svhdesc
from tests.support import VARIANTS


@pytest.mark.parametrize("variant", VARIANTS)
def test_scene_holds_home_and_test_for_two_seconds(variant: str) -> None:
    model = svhdesc.load_mujoco(variant, scene=True)
    data = mujoco.MjData(model)
    for key in ("home", "test"):
        mujoco.mj_resetDataKeyframe(model, data, model.key(key).id)
        while data.time < 2.0:
            mujoco.mj_step(model, data)
        for actuator in range(model.nu):
            joint = model.actuator_trnid[actuator, 0]
            error = abs(data.qpos[model.jnt_qposadr[joint]] - model.key(key).ctrl[actuator])
            arm = "_hand_" not in model.actuator(actuator).name
            # A hand channel commanded onto its stop rests inside the stop's 1 mrad limit margin (Finger_Spread, with
            # two coupled spreads on their own margins, about 2 mrad).
            bound = 1e-3 if arm else 2e-3
            assert error <= bound, f"{variant} {key}: {model.actuator(actuator).name} off by {error:.2e} rad"
        assert not any(w.number for w in data.warning)


def test_gravity_compensation_counts_against_the_effort_limit() -> None:
    model = svhdesc.get("ur5_svh_right")
    compiled = svhdesc.load_mujoco("ur5_svh_right", scene=True)
    assert (compiled.body_gravcomp[1:][compiled.body_mass[1:] > 0] == 1.0).all()
    efforts = {
        j.get("name"): float(j.find("limit").get("effort"))
        for j in etree.parse(str(model.urdf_path)).iter("joint")
        if j.find("limit") is not None
    }
    for j in range(compiled.njnt):
        name = compiled.joint(j).name
        assert compiled.jnt_actgravcomp[j] == 1, name
        assert compiled.jnt_actfrclimited[j] == 1, name
        assert tuple(compiled.jnt_actfrcrange[j]) == (-efforts[name], efforts[name]), name
    # Without it, the arm sags: the compensation is what holds the pose.
    compiled.body_gravcomp[:] = 0.0
    data = mujoco.MjData(compiled)
    mujoco.mj_resetDataKeyframe(compiled, data, compiled.key("test").id)
    while data.time < 2.0:
        mujoco.mj_step(compiled, data)
    lift = compiled.joint("shoulder_lift_joint")
    assert abs(data.qpos[lift.qposadr[0]] - compiled.key("test").qpos[lift.qposadr[0]]) > 5e-3
    assert np.isfinite(data.qpos).all()
