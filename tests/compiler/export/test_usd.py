"""The USD layer of every variant, read with usd-core's own physics parser and held to the MJCF that MuJoCo compiles:
bodies where MuJoCo puts them, joint axes and limits, masses and principal inertias, the servos' drives, collision
hulls, and the 11 couplings as NewtonMimicAPI and PhysxMimicJointAPI with the spec's ratios.

Seeded faults, each failing here: the mimic ratio written inverted (coef1 = 1 / ratio); the 180-degree flip of a
joint on -z dropped (``FLIP``: the thumb's opposition axis reversed); the drive damping left per radian; the
principal axes left unrotated (``quat_from_matrix(axes)`` -> identity)."""

from __future__ import annotations

import math

import mujoco
import newton_usd_schemas  # noqa: F401  registers NewtonMimicAPI with usd-core
import numpy as np
import pytest
from pxr import Gf, Usd, UsdGeom, UsdPhysics

import svhdesc
from svhdesc.compiler.export.usd import DEG
from tests.support import VARIANTS

F32 = 1e-6  # relative: the schema's float32 attributes


def _stage(variant: str) -> Usd.Stage:
    return Usd.Stage.Open(str(svhdesc.get(variant).usd_path))


def _mujoco(variant: str) -> tuple[mujoco.MjModel, mujoco.MjData]:
    model = svhdesc.load_mujoco(variant)
    data = mujoco.MjData(model)
    mujoco.mj_kinematics(model, data)
    return model, data


def _bodies(model: mujoco.MjModel) -> list[int]:
    """The MJCF's bodies that are links (not the world, nor the massless frame holding the variant's class)."""
    return [b for b in range(1, model.nbody) if model.body_mass[b] > 0.0]


def _joints(stage: Usd.Stage) -> dict[str, Usd.Prim]:
    return {p.GetName(): p for p in stage.Traverse() if p.IsA(UsdPhysics.Joint)}


def _rotation(quat: Gf.Quatf | Gf.Quatd) -> np.ndarray:
    """The rotation matrix (column vectors) of a USD quaternion."""
    w, (x, y, z) = quat.GetReal(), quat.GetImaginary()
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
            [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
            [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
        ]
    )


@pytest.mark.parametrize("variant", VARIANTS)
def test_usd_physics_parses_one_articulation(variant: str) -> None:
    parsed = UsdPhysics.UsdPhysicsLoadStageFromPrimRange(_stage(variant), ["/"])
    model, _ = _mujoco(variant)
    (articulation,) = parsed[UsdPhysics.ObjectType.Articulation][1]
    revolute = parsed[UsdPhysics.ObjectType.RevoluteJoint][0]
    assert len(revolute) == model.njnt
    assert len(parsed[UsdPhysics.ObjectType.RigidBody][0]) == len(_bodies(model))
    assert len(articulation.articulatedJoints) == len(revolute) + len(parsed[UsdPhysics.ObjectType.FixedJoint][0])
    collision_geoms = int(np.sum(model.geom_group == 3))
    assert len(parsed[UsdPhysics.ObjectType.MeshShape][0]) == collision_geoms


@pytest.mark.parametrize("variant", VARIANTS)
def test_bodies_masses_and_inertias_as_mujoco_compiles_them(variant: str) -> None:
    stage = _stage(variant)
    model, data = _mujoco(variant)
    cache = UsdGeom.XformCache()
    root = stage.GetDefaultPrim().GetPath()
    total = 0.0
    for b in _bodies(model):
        prim = stage.GetPrimAtPath(root.AppendChild(model.body(b).name))
        world = cache.GetLocalToWorldTransform(prim)
        assert np.allclose(np.array(world.ExtractTranslation()), data.xpos[b], atol=1e-9), model.body(b).name
        assert np.allclose(np.array(world.ExtractRotationMatrix()).T, data.xmat[b].reshape(3, 3), atol=1e-9)
        mass = UsdPhysics.MassAPI(prim)
        total += mass.GetMassAttr().Get()
        assert math.isclose(mass.GetMassAttr().Get(), model.body_mass[b], rel_tol=F32)
        com = np.array(mass.GetCenterOfMassAttr().Get())
        assert np.allclose(com, _local(data, b), atol=1e-7)
        moments = np.array(mass.GetDiagonalInertiaAttr().Get())
        axes = _rotation(mass.GetPrincipalAxesAttr().Get())
        tensor = axes @ np.diag(moments) @ axes.T  # in the body frame
        mj_axes = data.xmat[b].reshape(3, 3).T @ data.ximat[b].reshape(3, 3)
        mj_tensor = mj_axes @ np.diag(model.body_inertia[b]) @ mj_axes.T
        assert np.allclose(tensor, mj_tensor, atol=1e-6 * max(model.body_inertia[b])), model.body(b).name
    assert math.isclose(total, float(np.sum(model.body_mass)), rel_tol=1e-6)


def _local(data: mujoco.MjData, b: int) -> np.ndarray:
    """The centre of mass in the body's frame."""
    return data.xmat[b].reshape(3, 3).T @ (data.xipos[b] - data.xpos[b])


@pytest.mark.parametrize("variant", VARIANTS)
def test_joint_axes_limits_and_drives(variant: str) -> None:
    stage = _stage(variant)
    model, data = _mujoco(variant)
    joints = _joints(stage)
    cache = UsdGeom.XformCache()
    units = {"X": (1, 0, 0), "Y": (0, 1, 0), "Z": (0, 0, 1)}
    for j in range(model.njnt):
        prim = joints[model.joint(j).name]
        joint = UsdPhysics.RevoluteJoint(prim)
        child = stage.GetPrimAtPath(joint.GetBody1Rel().GetTargets()[0])
        world = np.array(cache.GetLocalToWorldTransform(child).ExtractRotationMatrix()).T
        axis = world @ _rotation(joint.GetLocalRot1Attr().Get()) @ np.array(units[joint.GetAxisAttr().Get()])
        assert np.allclose(axis, data.xaxis[j], atol=1e-6), model.joint(j).name
        lower, upper = joint.GetLowerLimitAttr().Get() / DEG, joint.GetUpperLimitAttr().Get() / DEG
        assert np.allclose([lower, upper], model.jnt_range[j], atol=1e-6)
    for a in range(model.nu):
        drive = UsdPhysics.DriveAPI(joints[model.joint(model.actuator_trnid[a, 0]).name], "angular")
        assert math.isclose(drive.GetStiffnessAttr().Get() * DEG, model.actuator_gainprm[a, 0], rel_tol=F32)
        assert math.isclose(drive.GetDampingAttr().Get() * DEG, -model.actuator_biasprm[a, 2], rel_tol=F32)
        assert math.isclose(drive.GetMaxForceAttr().Get(), model.actuator_forcerange[a, 1], rel_tol=F32)
    driven = {model.joint(model.actuator_trnid[a, 0]).name for a in range(model.nu)}
    assert not [n for n, p in joints.items() if n not in driven and p.HasAPI(UsdPhysics.DriveAPI, "angular")]


@pytest.mark.parametrize("variant", VARIANTS)
def test_the_couplings_as_newton_and_physx_mimics(variant: str) -> None:
    stage = _stage(variant)
    model, _ = _mujoco(variant)
    joints = _joints(stage)
    mimics = {n: p for n, p in joints.items() if p.HasAPI("NewtonMimicAPI")}
    equalities = [e for e in range(model.neq) if model.eq_type[e] == mujoco.mjtEq.mjEQ_JOINT]
    assert len(mimics) == len(equalities) == 11
    for e in equalities:
        follower, leader = model.joint(model.eq_obj1id[e]).name, model.joint(model.eq_obj2id[e]).name
        offset, ratio = model.eq_data[e, 0], model.eq_data[e, 1]
        prim = mimics[follower]
        leader_path = joints[leader].GetPath()
        assert prim.GetRelationship("newton:mimicJoint").GetTargets() == [leader_path]
        assert math.isclose(prim.GetAttribute("newton:mimicCoef1").Get(), ratio, rel_tol=F32)
        assert math.isclose(prim.GetAttribute("newton:mimicCoef0").Get() / DEG, offset, abs_tol=1e-7)
        axis = UsdPhysics.RevoluteJoint(prim).GetAxisAttr().Get()
        # PhysX's schema is not registered with usd-core: read the authored list, as Newton and Isaac Sim do.
        assert f"PhysxMimicJointAPI:rot{axis}" in prim.GetMetadata("apiSchemas").GetAppliedItems()
        assert prim.GetRelationship(f"physxMimicJoint:rot{axis}:referenceJoint").GetTargets() == [leader_path]
        assert math.isclose(prim.GetAttribute(f"physxMimicJoint:rot{axis}:gearing").Get(), -ratio, rel_tol=F32)
        assert math.isclose(prim.GetAttribute(f"physxMimicJoint:rot{axis}:offset").Get(), -offset, abs_tol=1e-7)


def test_principal_axes_of_equal_moments_do_not_turn_with_the_last_bits() -> None:
    """A cylinder's two equal moments leave their axes free in the eigensolver: a few ulps turned them (another CPU
    would write another USD). The axes are chosen, not found, there (moved by ulps at most), and still give back the
    tensor. Seeded fault:
    ``DEGENERATE = 0`` (axes from the eigensolver alone): the perturbed axes differ."""
    from svhdesc.compiler.export.usd import principal_axes

    turn = np.array([[0.36, 0.48, -0.8], [-0.8, 0.6, 0.0], [0.48, 0.64, 0.6]])  # a rotation
    tensor = turn @ np.diag([1.0e-4, 2.9e-4, 2.9e-4]) @ turn.T
    flat = (tensor[0, 0], tensor[0, 1], tensor[0, 2], tensor[1, 1], tensor[1, 2], tensor[2, 2])
    moments, axes = principal_axes(flat)
    assert np.allclose(axes @ np.diag(moments) @ axes.T, tensor, rtol=0, atol=1e-15)
    assert np.isclose(np.linalg.det(axes), 1.0)
    for ulps in (1, 4, 16):
        nudged = tuple(v * (1.0 + ulps * 2.2e-16) if i % 2 else v for i, v in enumerate(flat))
        assert np.allclose(principal_axes(nudged)[1], axes, rtol=0, atol=1e-12), ulps
