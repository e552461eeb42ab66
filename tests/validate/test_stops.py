"""svhdesc.validate.stops: what holds a fingertip's contact, the servos or the joint stops, on a one-joint finger.

A sphere on a vertical slide (range 0 .. 0.1 m) under a fixed box. Pushed down into its lower stop by a box that
overlaps it there, the stop holds most of the contact; pressed up into the box by its servo, the servo does. Seeded
faults: ``load`` reading the equality rows instead of the joint-limit rows (no stop force: the first test fails);
the contact force left in the contact frame instead of the world's (its load on the slide is wrong: both fail).
"""

from __future__ import annotations

import mujoco
import pytest

from svhdesc.validate.stops import load

FINGER = """
<mujoco>
  <option gravity="0 0 0"/>
  <worldbody>
    <geom name="box" type="box" size="0.05 0.05 0.01" pos="0 0 {box_bottom_plus}"/>
    <body name="tip">
      <joint name="slide" type="slide" axis="0 0 1" range="0 0.1" limited="true"/>
      <geom name="pad" type="sphere" size="0.01" mass="0.01"/>
    </body>
  </worldbody>
  <actuator><position name="servo" joint="slide" kp="100" ctrlrange="0 0.1"/></actuator>
</mujoco>
"""


def settled(box_bottom: float, target: float) -> tuple[mujoco.MjModel, mujoco.MjData]:
    model = mujoco.MjModel.from_xml_string(FINGER.format(box_bottom_plus=box_bottom + 0.01))
    data = mujoco.MjData(model)
    data.ctrl[:] = target
    for _ in range(1000):
        mujoco.mj_step(model, data)
    mujoco.mj_forward(model, data)
    return model, data


def contacts(data: mujoco.MjData) -> list[int]:
    return list(range(data.ncon))


def test_a_box_pushing_the_finger_into_its_stop_is_held_by_the_stop() -> None:
    model, data = settled(box_bottom=0.008, target=0.0)  # 2 mm into the sphere at the lower stop
    held = load(model, data, model.body("tip").id, contacts(data))
    assert data.ncon > 0 and held.contact["slide"] > 0.1
    # The stop (soft: the finger sinks below 0) and the servo pulling back to 0 balance the contact between them.
    assert held.stops["slide"] + data.qfrc_actuator[0] == pytest.approx(held.contact["slide"], rel=0.02)
    assert held.held_by_stops and held.stop_share == held.stops["slide"] / held.contact["slide"] > 0.5
    assert held.stopped_joints() == ["slide"]
    assert "the joint stops hold" in held.describe() and "slide" in held.describe()


def test_a_servo_pressing_into_the_box_holds_the_contact() -> None:
    model, data = settled(box_bottom=0.05, target=0.1)  # the box stops the finger near 0.04 m, short of 0.1
    held = load(model, data, model.body("tip").id, contacts(data))
    assert data.ncon > 0 and held.contact["slide"] == pytest.approx(100 * (0.1 - data.qpos[0]), rel=0.05)
    assert not held.held_by_stops and held.stops == {} and held.stop_share == 0.0
    assert held.describe().startswith("the servos hold the contact")
