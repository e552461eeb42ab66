"""The contract for a built model (svhdesc.model): couplings, joints and actuators read from the shipped models, the
configuration that built one, its manifest and mesh files."""

from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np
import pytest

import svhdesc
from svhdesc.model import Coupling, Model, actuated_joints, couplings, scalar_joints, urdf_couplings
from svhdesc.polynomial import polyval


@pytest.fixture(scope="module")
def right_hand() -> tuple[Model, object]:
    mujoco = pytest.importorskip("mujoco")
    model = svhdesc.get("svh_right")
    return model, mujoco.MjModel.from_xml_path(str(model.mjcf_path))


def test_mjcf_and_urdf_couplings_are_the_same_eleven(right_hand: tuple[Model, object]) -> None:
    model, mj = right_hand
    from_mjcf = {c.joint: c for c in couplings(mj)}
    from_urdf = {c.joint: c for c in urdf_couplings(model.urdf_path)}
    assert len(from_mjcf) == 11 and from_mjcf.keys() == from_urdf.keys()
    for joint, equality in from_mjcf.items():
        mimic = from_urdf[joint]
        assert equality.leader == mimic.leader and equality.leader.startswith("right_hand_")
        assert equality.name  # an MJCF equality is named; a <mimic> is not
        # The shipped hand's couplings are linear: the URDF carries them exactly.
        assert (equality.offset, equality.multiplier) == pytest.approx((mimic.offset, mimic.multiplier), abs=1e-12)


def test_joints_and_actuators(right_hand: tuple[Model, object]) -> None:
    _, mj = right_hand
    joints = [mj.joint(j).name for j in scalar_joints(mj)]
    actuated = actuated_joints(mj)
    assert len(joints) == 20 and len(actuated) == 9
    assert set(actuated) <= set(joints)
    assert not {c.joint for c in couplings(mj)} & set(actuated)  # a coupled joint is never driven itself
    low, high = actuated["right_hand_Pinky"]
    assert low < high


def test_a_coupling_evaluates_its_polynomial() -> None:
    coupling = Coupling("j", "channel", (0.1, 2.0, -0.5))
    q = np.linspace(-1.0, 1.0, 5)
    assert np.array_equal(coupling.value(q), polyval(coupling.coeffs, q))
    assert coupling.value(1.0) == pytest.approx(0.1 + 2.0 - 0.5)
    assert not coupling.linear
    with pytest.raises(ValueError, match="order > 1"):
        coupling.multiplier  # noqa: B018 - the property is the test
    linear = Coupling("j", "channel", (0.1, 2.0, 0.0, 0.0, 0.0))
    assert linear.linear and (linear.offset, linear.multiplier) == (0.1, 2.0)


def test_the_configuration_that_built_a_model() -> None:
    configuration = svhdesc.get("ur5_svh_right").configuration()
    assert configuration is not None
    assert configuration.variant == "ur5_svh_right"
    assert configuration.settings.hand.prefix == "right_hand"
    assert configuration.args.get("side") == "right"
    channels = configuration.channels()
    assert len(channels) == 9 and "Thumb_Flexion" in channels


def test_a_model_no_config_describes(tmp_path: Path) -> None:
    shipped = svhdesc.get("svh_right")
    stranger = tmp_path / "stranger"
    stranger.mkdir()
    for name in ("svh_right.xml", "svh_right.urdf"):
        shutil.copy(shipped.directory / name, stranger / name.replace("svh_right", "stranger"))
    model = Model("stranger", stranger)
    assert model.configuration() is None and model.manifest() is None
    assert shipped.manifest() is not None and "inputs" in shipped.manifest()


def test_mesh_files_of_a_built_model() -> None:
    model = svhdesc.get("svh_right")
    uri = next(u for u in (m.get("filename") for m in _meshes(model.urdf_path)) if u.startswith("package://"))
    path = model.mesh_file(uri)
    assert path is not None and path.is_file() and path.is_relative_to(model.directory)
    assert model.mesh_file("https://example.com/mesh.stl") is None
    assert model.mesh_file("assets/x.stl") == model.directory / "assets" / "x.stl"


def _meshes(urdf: Path) -> list:
    from lxml import etree

    return list(etree.parse(str(urdf)).getroot().iter("mesh"))
