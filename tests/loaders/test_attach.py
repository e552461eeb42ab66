"""svhdesc.attach: a built hand fixed to any MJCF arm by MjSpec's attach, against the compiled variant.

The UR5 alone (examples/ur5, from the vendor's ur_description) with svh_right attached at tool0 with the shipped
32 mm offset is the model the compiler builds as ur5_svh_right: the same joints, actuators, equalities, contact
exclusions (those across the seam included), body masses and keyframes, and the same forward kinematics.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import svhdesc
from tests.support import VENDOR_UR, run_cli

mujoco = pytest.importorskip("mujoco")
pytestmark = [
    pytest.mark.slow,  # builds the UR5 alone (about 10 s)
    pytest.mark.filterwarnings("ignore:Attaching a spec with an empty prefix"),  # the driver's names kept on purpose
]

UR5 = Path(__file__).parents[2] / "examples" / "ur5" / "ur5.yaml"


@pytest.fixture(scope="module")
def ur5_alone(tmp_path_factory: pytest.TempPathFactory) -> Path:
    if not VENDOR_UR.is_dir():
        pytest.skip(f"no vendor ur_description at {VENDOR_UR}")
    out = tmp_path_factory.mktemp("ur5") / "out"
    args = ("build", "--config", str(UR5), "--out", str(out), "--package", f"ur_description={VENDOR_UR}")
    result = run_cli(*args, in_process=True)
    assert result.returncode == 0, result.stderr
    return out / "ur5" / "ur5.xml"


@pytest.fixture(scope="module")
def attached(ur5_alone: Path) -> tuple:
    spec = svhdesc.attach(ur5_alone, "svh_right", parent="tool0", pos=(0, 0, 0.032))
    return spec.compile(), svhdesc.load_mujoco("ur5_svh_right")


def exclusions(model) -> set[frozenset[str]]:
    return {
        frozenset((model.body(int(s) >> 16).name, model.body(int(s) & 0xFFFF).name)) for s in model.exclude_signature
    }


def actuators(model) -> dict[str, tuple]:
    return {
        model.actuator(a).name: (
            model.joint(int(model.actuator_trnid[a, 0])).name,
            float(model.actuator_gainprm[a, 0]),
            tuple(model.actuator_ctrlrange[a]),
            tuple(model.actuator_forcerange[a]),
        )
        for a in range(model.nu)
    }


def equalities(model) -> set[tuple]:
    return {
        (
            model.joint(int(model.eq_obj1id[e])).name,
            model.joint(int(model.eq_obj2id[e])).name,
            tuple(model.eq_data[e, :5]),
        )
        for e in range(model.neq)
    }


def test_attach_equals_the_compiled_variant(attached: tuple) -> None:
    """Seeded faults: no exclusions across the seam (3 pairs short), the hand at tool0 without the offset (forward
    kinematics 32 mm off), keyframes not merged (MuJoCo refuses the two `home`s) each fail it."""
    model, compiled = attached
    assert [model.joint(j).name for j in range(model.njnt)] == [compiled.joint(j).name for j in range(compiled.njnt)]
    assert actuators(model) == actuators(compiled)
    assert equalities(model) == equalities(compiled) and len(equalities(model)) == 11
    assert exclusions(model) == exclusions(compiled)
    assert {"wrist_3_link", "right_hand_e1"} in exclusions(model)  # across the seam: touching at rest
    masses = {model.body(b).name: float(model.body_mass[b]) for b in range(model.nbody)}
    shipped = {compiled.body(b).name: float(compiled.body_mass[b]) for b in range(compiled.nbody)}
    common = set(masses) & set(shipped)
    assert {name for name in common if name.startswith("right_hand")} == {
        n for n in shipped if n.startswith("right_hand")
    }
    assert all(masses[name] == pytest.approx(shipped[name], abs=1e-12) for name in common)
    assert model.opt.timestep == compiled.opt.timestep and model.nsensor == compiled.nsensor == 1
    assert [model.key(k).name for k in range(model.nkey)] == [compiled.key(k).name for k in range(compiled.nkey)]
    data, reference = mujoco.MjData(model), mujoco.MjData(compiled)
    mujoco.mj_resetDataKeyframe(compiled, reference, compiled.key("test").id)
    for j in range(compiled.njnt):
        data.qpos[model.jnt_qposadr[model.joint(compiled.joint(j).name).id]] = reference.qpos[compiled.jnt_qposadr[j]]
    mujoco.mj_kinematics(model, data)
    mujoco.mj_kinematics(compiled, reference)
    for name in common - {"world"}:
        assert np.abs(data.xpos[model.body(name).id] - reference.xpos[compiled.body(name).id]).max() < 1e-9, name
        assert np.abs(data.xmat[model.body(name).id] - reference.xmat[compiled.body(name).id]).max() < 1e-9, name


def test_keyframes_merge_by_name(ur5_alone: Path, attached: tuple) -> None:
    """`fist` is the hand's alone: the arm holds its own `home` there; `home` takes each part's `home`."""
    model, _ = attached
    arm = mujoco.MjModel.from_xml_path(str(ur5_alone))
    hand = svhdesc.load_mujoco("svh_right")

    def position(m, key: str, joint: str) -> float:
        return float(m.key(key).qpos[m.jnt_qposadr[m.joint(joint).id]])

    for key, arm_key in (("home", "home"), ("fist", "home")):
        assert position(model, key, "elbow_joint") == position(arm, arm_key, "elbow_joint") != 0.0
        assert position(model, key, "right_hand_j13") == position(hand, key, "right_hand_j13")
        ctrl = model.key(key).ctrl[model.actuator("right_hand_Pinky").id]
        assert ctrl == hand.key(key).ctrl[hand.actuator("right_hand_Pinky").id]
    assert position(model, "fist", "right_hand_j13") != 0.0


def test_the_arm_spec_is_left_as_it_was_and_a_wrong_parent_is_named(ur5_alone: Path) -> None:
    arm = mujoco.MjSpec.from_file(str(ur5_alone))
    bodies = len(list(arm.bodies))
    spec = svhdesc.attach(arm, "svh_right", parent="tool0")
    assert len(list(arm.bodies)) == bodies < len(list(spec.bodies))
    with pytest.raises(ValueError, match="the arm has no body 'nowhere'"):
        svhdesc.attach(arm, "svh_right", parent="nowhere")
