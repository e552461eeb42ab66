"""IR -> USD (``{robot}.usda``) for Isaac Sim / Isaac Lab (PhysX) and Newton, written with usd-core.

One self-contained layer: every link a rigid body (``UsdPhysics``) at its place in the zero pose, with its mass,
centre of mass and principal inertia; its visual meshes and its collision hulls (convex, purpose ``guide``) inline;
revolute (continuous: without limits), prismatic and fixed joints with their limits; an angular (linear) drive on
every servo with the MJCF's gains (kp, and the kv MuJoCo derives from ``dampratio``: the damping probe's result); and
each coupled joint as a mimic of its channel in both schemas that read one: ``NewtonMimicAPI`` (Newton: ``joint =
coef0 + coef1 * leader``, coef0 in degrees or metres) and PhysX's ``PhysxMimicJointAPI:rot?`` (``trans?`` for a
prismatic joint; Isaac: ``joint + gearing * leader + offset = 0``, offset in radians or metres).

USD states angles in degrees and lengths in the stage's unit (metres here): a revolute joint's limits, drive gains
(per degree), damping and velocity limits are converted with one scalar factor each (``unit``), a prismatic
joint's are written as they are. Schema attributes are float32 where the schema says so (joint frames, masses,
inertias).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
from pxr import Gf, Sdf, Tf, Usd, UsdGeom, UsdPhysics, UsdShade, Vt

from svhdesc.compiler.assets import Assets
from svhdesc.compiler.export.urdf import mimic_line
from svhdesc.core import exact
from svhdesc.core.frames import axis_frame, pose_matrix
from svhdesc.ir import Geometry, Joint, Link, Robot

DEG = 180.0 / math.pi  # USD's angular unit per radian
AXES = {(1.0, 0.0, 0.0): "X", (0.0, 1.0, 0.0): "Y", (0.0, 0.0, 1.0): "Z"}
FLIP = {"X": (0.0, 0.0, 1.0, 0.0), "Y": (0.0, 0.0, 0.0, 1.0), "Z": (0.0, 1.0, 0.0, 0.0)}  # 180 deg about another axis


def quat_from_matrix(rotation: np.ndarray) -> tuple[float, float, float, float]:
    """(w, x, y, z) of a rotation matrix (Shepperd's method in scalar math), w >= 0."""
    m = [[float(rotation[i][j]) for j in range(3)] for i in range(3)]
    trace = m[0][0] + m[1][1] + m[2][2]
    if trace > 0.0:
        s = 2.0 * math.sqrt(trace + 1.0)
        q = (0.25 * s, (m[2][1] - m[1][2]) / s, (m[0][2] - m[2][0]) / s, (m[1][0] - m[0][1]) / s)
    elif m[0][0] > m[1][1] and m[0][0] > m[2][2]:
        s = 2.0 * math.sqrt(1.0 + m[0][0] - m[1][1] - m[2][2])
        q = ((m[2][1] - m[1][2]) / s, 0.25 * s, (m[0][1] + m[1][0]) / s, (m[0][2] + m[2][0]) / s)
    elif m[1][1] > m[2][2]:
        s = 2.0 * math.sqrt(1.0 + m[1][1] - m[0][0] - m[2][2])
        q = ((m[0][2] - m[2][0]) / s, (m[0][1] + m[1][0]) / s, 0.25 * s, (m[1][2] + m[2][1]) / s)
    else:
        s = 2.0 * math.sqrt(1.0 + m[2][2] - m[0][0] - m[1][1])
        q = ((m[1][0] - m[0][1]) / s, (m[0][2] + m[2][0]) / s, (m[1][2] + m[2][1]) / s, 0.25 * s)
    return q if q[0] >= 0.0 else (-q[0], -q[1], -q[2], -q[3])


def quat_multiply(a: Sequence[float], b: Sequence[float]) -> tuple[float, float, float, float]:
    aw, ax, ay, az = a
    bw, bx, by, bz = b
    return (
        aw * bw - ax * bx - ay * by - az * bz,
        aw * bx + ax * bw + ay * bz - az * by,
        aw * by - ax * bz + ay * bw + az * bx,
        aw * bz + ax * by - ay * bx + az * bw,
    )


def joint_axis(joint: Joint) -> tuple[str, tuple[float, float, float, float]]:
    """USD's axis token and the rotation (w, x, y, z) from the joint frame to the IR's child link frame."""
    axis = tuple(float(v) for v in joint.axis)
    if axis in AXES:
        return AXES[axis], (1.0, 0.0, 0.0, 0.0)
    negative = tuple(-v for v in axis)
    if negative in AXES:
        return AXES[negative], FLIP[AXES[negative]]
    return "Z", quat_from_matrix(axis_frame(np.array(axis)))


def world_poses(robot: Robot) -> dict[str, np.ndarray]:
    """Each link's 4x4 pose in the root's frame at the zero pose (every joint at 0)."""
    poses = {robot.root: np.eye(4)}
    pending = list(robot.child_joints(robot.root))
    while pending:
        joint = pending.pop(0)
        poses[joint.child] = exact.matmul(poses[joint.parent], pose_matrix(joint.origin))
        pending.extend(robot.child_joints(joint.child))
    return poses


def prim_name(name: str) -> str:
    return Tf.MakeValidIdentifier(name)


def _set_pose(xformable: UsdGeom.Xformable, matrix: np.ndarray, scale: Sequence[float] | None = None) -> None:
    xformable.AddTranslateOp(UsdGeom.XformOp.PrecisionDouble).Set(Gf.Vec3d(*(float(v) for v in matrix[:3, 3])))
    w, x, y, z = quat_from_matrix(matrix[:3, :3])
    xformable.AddOrientOp(UsdGeom.XformOp.PrecisionDouble).Set(Gf.Quatd(w, x, y, z))
    if scale is not None and tuple(scale) != (1.0, 1.0, 1.0):
        xformable.AddScaleOp(UsdGeom.XformOp.PrecisionDouble).Set(Gf.Vec3d(*(float(v) for v in scale)))


def _mesh(stage: Usd.Stage, path: Sdf.Path, geometry: Geometry, assets: Assets) -> UsdGeom.Gprim:
    mesh = UsdGeom.Mesh.Define(stage, path)
    source = assets.meshes[geometry.mesh]
    # Vertices as float32 (what the STL and OBJ files hold), each distinct one once: an exact, sorted merge.
    points, inverse = np.unique(np.asarray(source.vertices, dtype=np.float32), axis=0, return_inverse=True)
    faces = np.asarray(inverse.reshape(-1)[np.asarray(source.faces)], dtype=np.int32)
    mesh.CreatePointsAttr(Vt.Vec3fArray.FromNumpy(points))
    mesh.CreateFaceVertexCountsAttr(Vt.IntArray.FromNumpy(np.full(len(faces), 3, dtype=np.int32)))
    mesh.CreateFaceVertexIndicesAttr(Vt.IntArray.FromNumpy(faces.reshape(-1)))
    mesh.CreateSubdivisionSchemeAttr(UsdGeom.Tokens.none)
    low, high = points.min(axis=0), points.max(axis=0)  # min and max: exact on any CPU
    mesh.CreateExtentAttr(Vt.Vec3fArray([Gf.Vec3f(*map(float, low)), Gf.Vec3f(*map(float, high))]))
    return mesh


def _shape(stage: Usd.Stage, path: Sdf.Path, geometry: Geometry, assets: Assets) -> UsdGeom.Gprim:
    """A mesh, or the primitive USD has for the IR's box, cylinder, capsule or sphere."""
    size = geometry.size
    if geometry.kind == "mesh":
        return _mesh(stage, path, geometry, assets)
    if geometry.kind == "box":
        cube = UsdGeom.Cube.Define(stage, path)
        cube.CreateSizeAttr(1.0)
        cube.AddScaleOp(UsdGeom.XformOp.PrecisionDouble).Set(Gf.Vec3d(*(float(v) for v in size)))
        return cube
    if geometry.kind == "sphere":
        sphere = UsdGeom.Sphere.Define(stage, path)
        sphere.CreateRadiusAttr(float(size[0]))
        return sphere
    shape = (UsdGeom.Capsule if geometry.kind == "capsule" else UsdGeom.Cylinder).Define(stage, path)
    shape.CreateRadiusAttr(float(size[0]))
    shape.CreateHeightAttr(float(size[1]))
    shape.CreateAxisAttr(UsdGeom.Tokens.z)
    return shape


def _geometry(stage: Usd.Stage, path: Sdf.Path, geometry: Geometry, assets: Assets) -> UsdGeom.Gprim:
    holder = UsdGeom.Xform.Define(stage, path)
    _set_pose(holder, pose_matrix(geometry.origin), geometry.scale)
    shape = _shape(stage, path.AppendChild("shape"), geometry, assets)
    if geometry.rgba is not None:
        shape.CreateDisplayColorAttr(Vt.Vec3fArray([Gf.Vec3f(*(float(c) for c in geometry.rgba[:3]))]))
        if geometry.rgba[3] < 1.0:
            shape.CreateDisplayOpacityAttr(Vt.FloatArray([float(geometry.rgba[3])]))
    return shape


DEGENERATE = 1e-9  # relative: principal moments this close are one moment (a cylinder's two equal ones)


def _canonical(vector: np.ndarray) -> np.ndarray:
    """A unit eigenvector's sign fixed: its largest component positive."""
    return vector if vector[int(np.argmax(np.abs(vector)))] > 0.0 else -vector


def _plane_axis(normal: np.ndarray) -> np.ndarray:
    """A unit vector perpendicular to ``normal``, from the coordinate axis least aligned with it: the axis chosen
    inside a degenerate pair of moments, whichever the eigensolver returned (a few ulps would turn it)."""
    helper = np.eye(3)[int(np.argmin(np.abs(normal)))]
    u = helper - exact.fsum(helper * normal) * normal
    return u / exact.norm(u)


def principal_axes(inertia: tuple[float, ...]) -> tuple[np.ndarray, np.ndarray]:
    """Principal moments (ascending) and the rotation whose columns are their axes, the same on any CPU: the
    plain-Python eigensolver, each axis' sign fixed, and any axis inside a degenerate pair chosen by ``_plane_axis``."""
    ixx, ixy, ixz, iyy, iyz, izz = inertia
    moments, axes = exact.eigh3(np.array([[ixx, ixy, ixz], [ixy, iyy, iyz], [ixz, iyz, izz]]))
    close = [abs(moments[i + 1] - moments[i]) <= DEGENERATE * abs(moments[2]) for i in range(2)]
    if all(close):
        return moments, np.eye(3)
    if close[0]:  # the first two equal: the third axis is the one defined
        third = _canonical(axes[:, 2])
        first = _plane_axis(third)
        return moments, np.column_stack([first, np.cross(third, first), third])
    first = _canonical(axes[:, 0])
    second = _plane_axis(first) if close[1] else _canonical(axes[:, 1])
    return moments, np.column_stack([first, second, np.cross(first, second)])


def _mass(prim: Usd.Prim, link: Link) -> None:
    """Mass, centre of mass and the inertia tensor as principal moments and axes."""
    inertial = link.inertial
    assert inertial is not None
    mass = UsdPhysics.MassAPI.Apply(prim)
    mass.CreateMassAttr(float(inertial.mass))
    mass.CreateCenterOfMassAttr(Gf.Vec3f(*(float(v) for v in inertial.com)))
    moments, axes = principal_axes(inertial.inertia)
    mass.CreateDiagonalInertiaAttr(Gf.Vec3f(*(float(v) for v in moments)))
    w, x, y, z = quat_from_matrix(axes)
    mass.CreatePrincipalAxesAttr(Gf.Quatf(w, x, y, z))


def _materials(stage: Usd.Stage, root: Sdf.Path, robot: Robot) -> dict[tuple[float, ...], UsdShade.Material]:
    """One physics material per distinct contact (friction) of the links."""
    materials: dict[tuple[float, ...], UsdShade.Material] = {}
    contacts = sorted({(link.contact.mu,) for link in robot.links if link.contact is not None and link.collisions})
    if contacts:
        UsdGeom.Scope.Define(stage, root.AppendChild("materials"))
    for i, key in enumerate(contacts):
        material = UsdShade.Material.Define(stage, root.AppendPath(f"materials/contact_{i}"))
        api = UsdPhysics.MaterialAPI.Apply(material.GetPrim())
        api.CreateStaticFrictionAttr(float(key[0]))
        api.CreateDynamicFrictionAttr(float(key[0]))
        api.CreateRestitutionAttr(0.0)
        materials[key] = material
    return materials


def _body(stage: Usd.Stage, path: Sdf.Path, link: Link, pose: np.ndarray, assets: Assets) -> Usd.Prim:
    """The link as a rigid body (a static frame where it has no inertial: a massless root) with its shapes."""
    xform = UsdGeom.Xform.Define(stage, path)
    _set_pose(xform, pose)
    prim = xform.GetPrim()
    if link.inertial is not None:
        UsdPhysics.RigidBodyAPI.Apply(prim)
        _mass(prim, link)
    for i, geometry in enumerate(link.visuals):
        _geometry(stage, path.AppendChild(f"visual_{i:02d}"), geometry, assets)
    for i, geometry in enumerate(link.collisions):
        shape = _geometry(stage, path.AppendChild(f"collision_{i:02d}"), geometry, assets)
        shape.CreatePurposeAttr(UsdGeom.Tokens.guide)
        UsdPhysics.CollisionAPI.Apply(shape.GetPrim())
        if geometry.kind == "mesh":
            UsdPhysics.MeshCollisionAPI.Apply(shape.GetPrim()).CreateApproximationAttr(UsdPhysics.Tokens.convexHull)
    return prim


def _bind_material(stage: Usd.Stage, path: Sdf.Path, link: Link, materials: dict) -> None:
    if link.contact is None or (link.contact.mu,) not in materials:
        return
    for i in range(len(link.collisions)):
        shape = stage.GetPrimAtPath(path.AppendPath(f"collision_{i:02d}/shape"))
        binding = UsdShade.MaterialBindingAPI.Apply(shape)
        binding.Bind(materials[(link.contact.mu,)], UsdShade.Tokens.weakerThanDescendants, "physics")


def unit(joint: Joint) -> float:
    """USD's unit of the joint's position per IR unit: degrees per radian, or metres per metre (prismatic)."""
    return 1.0 if joint.type == "prismatic" else DEG


def _joint_prim(stage: Usd.Stage, path: Sdf.Path, joint: Joint, axis: str) -> Usd.Prim:
    if not joint.movable:
        return UsdPhysics.FixedJoint.Define(stage, path).GetPrim()
    kind = UsdPhysics.PrismaticJoint if joint.type == "prismatic" else UsdPhysics.RevoluteJoint
    usd_joint = kind.Define(stage, path)
    usd_joint.CreateAxisAttr(axis)
    if joint.type != "continuous":
        usd_joint.CreateLowerLimitAttr(float(joint.lower * unit(joint)))
        usd_joint.CreateUpperLimitAttr(float(joint.upper * unit(joint)))
    return usd_joint.GetPrim()


def _frames(usd_joint: UsdPhysics.Joint, parent: np.ndarray, to_child: tuple[float, float, float, float]) -> None:
    """Joint frame in the parent body (``parent``: the child link's pose in it) and in the child body."""
    w, x, y, z = quat_multiply(quat_from_matrix(parent[:3, :3]), to_child)
    usd_joint.CreateLocalPos0Attr(Gf.Vec3f(*(float(v) for v in parent[:3, 3])))
    usd_joint.CreateLocalRot0Attr(Gf.Quatf(w, x, y, z))
    usd_joint.CreateLocalPos1Attr(Gf.Vec3f(0.0, 0.0, 0.0))
    usd_joint.CreateLocalRot1Attr(Gf.Quatf(*to_child))


def _joint(stage: Usd.Stage, root: Sdf.Path, robot: Robot, joint: Joint, poses: dict[str, np.ndarray]) -> Usd.Prim:
    axis, to_child = joint_axis(joint) if joint.movable else ("X", (1.0, 0.0, 0.0, 0.0))
    prim = _joint_prim(stage, root.AppendPath(f"joints/{prim_name(joint.name)}"), joint, axis)
    usd_joint = UsdPhysics.Joint(prim)
    parent_is_body = robot.link(joint.parent).inertial is not None
    if parent_is_body:
        usd_joint.CreateBody0Rel().SetTargets([root.AppendChild(prim_name(joint.parent))])
    usd_joint.CreateBody1Rel().SetTargets([root.AppendChild(prim_name(joint.child))])
    # A parent that is no body (the massless root) is the world: the frame is the child's pose in the root's.
    _frames(usd_joint, pose_matrix(joint.origin) if parent_is_body else poses[joint.child], to_child)
    if joint.movable:
        newton, per = prim, unit(joint)
        newton.AddAppliedSchema("NewtonJointAPI")
        newton.CreateAttribute("newton:armature", Sdf.ValueTypeNames.Float).Set(float(joint.armature))
        newton.CreateAttribute("newton:damping", Sdf.ValueTypeNames.Float).Set(float(joint.damping / per))
        newton.CreateAttribute("newton:friction", Sdf.ValueTypeNames.Float).Set(float(joint.friction))
        newton.CreateAttribute("newton:velocityLimit", Sdf.ValueTypeNames.Float).Set(float(joint.velocity * per))
        newton.AddAppliedSchema("PhysxJointAPI")
        newton.CreateAttribute("physxJoint:armature", Sdf.ValueTypeNames.Float).Set(float(joint.armature))
        newton.CreateAttribute("physxJoint:jointFriction", Sdf.ValueTypeNames.Float).Set(float(joint.friction))
        newton.CreateAttribute("physxJoint:maxJointVelocity", Sdf.ValueTypeNames.Float).Set(float(joint.velocity * per))
    return prim


def _drive(prim: Usd.Prim, joint: Joint, kp: float, kv: float, effort: float) -> None:
    """A position servo: force = kp (target - q) - kv qdot, limited to the effort (gains per degree or metre); a
    velocity servo (kp 0): force = kv (target velocity - qdot), the drive's damping only."""
    linear = joint.type == "prismatic"
    drive = UsdPhysics.DriveAPI.Apply(prim, UsdPhysics.Tokens.linear if linear else UsdPhysics.Tokens.angular)
    drive.CreateTypeAttr(UsdPhysics.Tokens.force)
    drive.CreateStiffnessAttr(float(kp / unit(joint)))
    drive.CreateDampingAttr(float(kv / unit(joint)))
    drive.CreateMaxForceAttr(float(effort))
    if kp > 0:
        drive.CreateTargetPositionAttr(0.0)
    else:
        drive.CreateTargetVelocityAttr(0.0)


def _dof(joint: Joint) -> str:
    """PhysX's name of a single-axis joint's degree of freedom (a mimic's instance and its leader's axis)."""
    return f"{'trans' if joint.type == 'prismatic' else 'rot'}{joint_axis(joint)[0]}"


def _mimic(prim: Usd.Prim, leader: Sdf.Path, joints: tuple[Joint, Joint], offset: float, multiplier: float) -> None:
    """joint = offset + multiplier * leader, in Newton's schema and in PhysX's (the same line, its own signs): the
    offset in the follower's unit, the ratio in joint coordinates (radians, metres) in both. ``joints``: the
    follower and its leader."""
    joint, lead = joints
    prim.AddAppliedSchema("NewtonMimicAPI")
    prim.CreateAttribute("newton:mimicEnabled", Sdf.ValueTypeNames.Bool).Set(True)
    prim.CreateRelationship("newton:mimicJoint").SetTargets([leader])
    prim.CreateAttribute("newton:mimicCoef0", Sdf.ValueTypeNames.Float).Set(float(offset * unit(joint)))
    prim.CreateAttribute("newton:mimicCoef1", Sdf.ValueTypeNames.Float).Set(float(multiplier))
    instance = _dof(joint)
    prim.AddAppliedSchema(f"PhysxMimicJointAPI:{instance}")
    prim.CreateRelationship(f"physxMimicJoint:{instance}:referenceJoint").SetTargets([leader])
    prim.CreateAttribute(f"physxMimicJoint:{instance}:referenceJointAxis", Sdf.ValueTypeNames.Token).Set(_dof(lead))
    prim.CreateAttribute(f"physxMimicJoint:{instance}:gearing", Sdf.ValueTypeNames.Float).Set(float(-multiplier))
    prim.CreateAttribute(f"physxMimicJoint:{instance}:offset", Sdf.ValueTypeNames.Float).Set(0.0 - offset)


def _filtered_pairs(stage: Usd.Stage, root: Sdf.Path, robot: Robot) -> None:
    """The link pairs that never collide (the MJCF's excludes)."""
    bodies = {link.name for link in robot.links if link.inertial is not None}
    for a, b in robot.excludes:
        if a in bodies and b in bodies:
            api = UsdPhysics.FilteredPairsAPI.Apply(stage.GetPrimAtPath(root.AppendChild(prim_name(a))))
            api.CreateFilteredPairsRel().AddTarget(root.AppendChild(prim_name(b)))


# Properties of schemas usd-core does not ship (Newton's, PhysX's). USD writes them `custom` unless the exporting
# process has registered their schema (newton_usd_schemas does on import), so their bytes would depend on what else
# the process loaded: they are declared custom here, whatever is registered.
FOREIGN_NAMESPACES = ("newton:", "physx")


def _declare_custom(layer: Sdf.Layer) -> None:
    def visit(path: Sdf.Path) -> None:
        if path.IsPropertyPath() and path.name.startswith(FOREIGN_NAMESPACES):
            layer.GetPropertyAtPath(path).custom = True

    layer.Traverse(Sdf.Path.absoluteRootPath, visit)


def export_usd(robot: Robot, assets: Assets, damping: dict[str, float]) -> bytes:
    """The variant as one USD layer (text): ``damping`` is each servo's velocity gain (the damping probe's)."""
    layer = Sdf.Layer.CreateAnonymous(".usda")
    stage = Usd.Stage.Open(layer)
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.z)
    UsdGeom.SetStageMetersPerUnit(stage, 1.0)
    UsdPhysics.SetStageKilogramsPerUnit(stage, 1.0)
    root = Sdf.Path.absoluteRootPath.AppendChild(prim_name(robot.name))
    top = UsdGeom.Xform.Define(stage, root).GetPrim()
    stage.SetDefaultPrim(top)
    UsdPhysics.ArticulationRootAPI.Apply(top)
    materials = _materials(stage, root, robot)
    poses = world_poses(robot)
    for link in robot.links:
        if link.name == robot.root and link.inertial is None and not link.has_geometry:
            continue  # the world the robot is fixed to
        path = root.AppendChild(prim_name(link.name))
        _body(stage, path, link, poses[link.name], assets)
        _bind_material(stage, path, link, materials)
    UsdGeom.Scope.Define(stage, root.AppendChild("joints"))
    prims = {joint.name: _joint(stage, root, robot, joint, poses) for joint in robot.joints}
    for actuator in robot.actuators:
        kp = 0.0 if actuator.velocity else actuator.kp  # a velocity servo's kv is MuJoCo's (``damping``)
        _drive(prims[actuator.joint], robot.joint(actuator.joint), kp, damping[actuator.name], actuator.effort)
    for joint in robot.joints:
        if joint.mimic is not None:
            offset, multiplier = mimic_line(robot, joint)
            leader = robot.joint(joint.mimic.joint)
            _mimic(prims[joint.name], prims[leader.name].GetPath(), (joint, leader), offset, multiplier)
    _filtered_pairs(stage, root, robot)
    _declare_custom(layer)
    layer.documentation = f"{robot.name}: generated by svhdesc from one source; edit the sources, not this file."
    return layer.ExportToString().encode()
