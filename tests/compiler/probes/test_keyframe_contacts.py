"""Every keyframe of a built variant is a state the hand can be in: no two bodies interpenetrate deeper than the
processor's TOLERANCE (compiler/probes/keyframe_contacts.py), while the key's ctrl keeps the configured servo targets.

Seeded fault, checked here without another build: each key's configured pose (its ctrl on the channels, the coupled
joints following through the MJCF's equalities), which is what the build wrote without the processor, interpenetrates
by more than TOLERANCE in ``power`` and ``lateral``: the first test's bound fails on it.
"""

from __future__ import annotations

import mujoco
import numpy as np
import pytest
import yaml

from svhdesc.compiler.probes.keyframe_contacts import TOLERANCE, deepest
from tests.support import REPO, VARIANTS, model_files

CONFIG = yaml.safe_load((REPO / "config" / "svhdesc.yaml").read_text())
PREFIX = {"svh_right": "right_hand", "svh_left": "left_hand", "ur5_svh_right": "right_hand"}


def configured_pose(model: mujoco.MjModel, key: int) -> np.ndarray:
    """Key ``key``'s configured pose: its servo targets on the actuated joints, the coupled joints following."""
    qpos = model.key_qpos[key].copy()
    for a in range(model.nu):
        qpos[model.jnt_qposadr[model.actuator_trnid[a, 0]]] = model.key_ctrl[key][a]
    for e in np.flatnonzero(model.eq_type == mujoco.mjtEq.mjEQ_JOINT):
        follower, leader = model.eq_obj1id[e], model.eq_obj2id[e]
        x = qpos[model.jnt_qposadr[leader]]
        qpos[model.jnt_qposadr[follower]] = sum(c * x**i for i, c in enumerate(model.eq_data[e][:5]))
    return qpos


def depth(model: mujoco.MjModel, qpos: np.ndarray) -> float:
    data = mujoco.MjData(model)
    data.qpos[:] = qpos
    return deepest(model, data)


@pytest.mark.parametrize("variant", VARIANTS)
def test_no_keyframe_interpenetrates_and_ctrl_keeps_the_targets(variant: str) -> None:
    model = mujoco.MjModel.from_xml_path(str(model_files(variant)[1]))
    stopped = []
    for k in range(model.nkey):
        name = model.key(k).name
        assert depth(model, model.key_qpos[k]) <= TOLERANCE, name
        # the key's ctrl is the configured keyframe: every channel it names, at its configured value
        for channel, value in (CONFIG["keyframes"][name] or {}).items():
            joint = channel if channel.endswith("_joint") else f"{PREFIX[variant]}_{channel}"
            if joint in {model.joint(model.actuator_trnid[a, 0]).name for a in range(model.nu)}:
                assert model.key(k).ctrl[model.actuator(joint).id] == value, (name, channel)
        configured = configured_pose(model, k)
        if depth(model, configured) > TOLERANCE:
            stopped.append(name)
        else:  # a keyframe within the tolerance keeps its configured pose
            assert np.array_equal(model.key_qpos[k], configured), name
    # the seeded fault: the configured grasps close the fingers into each other, past the bound above
    assert {"power", "lateral"} <= set(stopped)
    assert "home" not in stopped and "test" not in stopped
