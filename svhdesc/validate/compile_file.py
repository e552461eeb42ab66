"""A robot file compiled by MuJoCo as it stands, for the full tier of `svhdesc validate PATH`.

An MJCF compiles as written. A URDF goes through MuJoCo's own URDF importer (its <mimic> tags become joint
equalities; every link stays a body of its own), with three changes that let a file with faults still be simulated, each
already a static-tier finding and each listed in the report's notes: meshes that do not resolve are left out,
<mimic> tags naming no movable joint are dropped, and, only when MuJoCo refuses the masses, they are bounded below.
Meshes MuJoCo cannot read (COLLADA, ASCII STL, ...) are converted to binary STL in a cache outside the repository.
Every movable joint that is not a mimic follower gets a position servo whose force is the joint's rated effort: the
robot as its datasheet says it is. Links a joint connects, and pairs of links in contact in every one of 17 poses,
do not collide: what Gazebo and pybullet leave out by default and MoveIt's setup assistant disables ("adjacent",
"always in collision").
"""

from __future__ import annotations

import copy
import hashlib
import os
import re
from collections.abc import Callable, Mapping
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from lxml import etree

from svhdesc.core.limits import mesh_size_problem
from svhdesc.errors import SvhdescError
from svhdesc.validate.poses import always_touching
from svhdesc.validate.static_urdf import MOVABLE, UrdfSource, resolve_mesh

# The servo's error at which it reaches its rated effort: stiff enough to hold, soft enough for the timestep.
SATURATION_ERROR = 0.05  # rad (m for a slide: 0.05 x its range)
OVERLAP_SAMPLES = 16  # poses besides the rest pose in which a pair of links must touch to count as always touching
_MUJOCO_MESHES = {".stl", ".obj", ".msh"}


@dataclass
class Compiled:
    model: object  # mujoco.MjModel
    # (tag, name) -> (file, line): a joint, body or actuator of the model at its line in the source
    where: Callable[[str, str], tuple[str, int | None]]
    # joint id -> the force it is rated for (URDF effort; an MJCF actuator's force bound); absent: unbounded
    rated: dict[int, float] = field(default_factory=dict)
    notes: list[str] = field(default_factory=list)
    kind: str = "urdf"
    # pairs of links in contact in every sampled pose, excluded from contact as MoveIt's setup assistant disables them
    overlapping: tuple[tuple[str, str], ...] = ()
    # joint id -> its velocity limit (URDF <limit velocity>), which a sweep of its servo respects
    velocity: dict[int, float] = field(default_factory=dict)
    # the keyframe the model rests in (the settings' keyframe, else 0)
    key: int = 0
    # joint name -> the settings' quirks for it (svhdesc.validate.settings.JointSettings)
    joints: Mapping[str, Any] = field(default_factory=dict)


class CompileFailed(SvhdescError):
    """MuJoCo does not open the model: the full tier's compile check fails with this message, at this line."""

    def __init__(self, message: str, file: str | None = None, line: int | None = None) -> None:
        super().__init__(message)
        self.file, self.line = file, line


def _refusal(exc: ValueError, source: UrdfSource, prepared: etree._Element) -> CompileFailed:
    """MuJoCo's refusal at the source's line: its 'line N' counts lines of the text MuJoCo was given (the prepared
    copy), which maps element by element onto the copy, whose elements keep the source's lines."""
    message = " ".join(str(exc).split())
    culprit = None
    at_line = re.search(r"Element '([\w:]+)', line (\d+)", message)
    named = re.search(r"Element name '([^']+)'", message)
    if at_line:
        text = etree.tostring(prepared)
        for given, copied in zip(etree.fromstring(text).iter(), prepared.iter()):
            if given.sourceline == int(at_line.group(2)) and given.tag == at_line.group(1):
                culprit = copied
                break
        message = message.replace(f", line {at_line.group(2)}", "")
    elif named:  # a joint and a link may share the name: the message says which kind it is about
        kinds = ("joint", "link") if "joint" in message.split("Element name")[0] else ("link", "joint")
        found = (prepared.find(f"{kind}[@name='{named.group(1)}']") for kind in kinds)
        culprit = next((element for element in found if element is not None), None)
    if culprit is None:
        return CompileFailed(message, str(source.path), None)
    if not source.xacro_files:
        return CompileFailed(message, str(source.path), culprit.sourceline)
    owner = culprit
    while owner is not None and not (owner.tag in {"link", "joint"} and owner.get("name")):
        owner = owner.getparent()
    original = source.root.find(f"{owner.tag}[@name='{owner.get('name')}']") if owner is not None else None
    file, line = source.where(original)
    return CompileFailed(message, file, line)


def mesh_cache() -> Path:
    base = Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache")
    return base / "svhdesc" / "validate-meshes"


def _binary_stl(path: Path) -> bool:
    """Whether ``path`` is a binary STL (MuJoCo reads no ASCII STL): its size is what its triangle count says."""
    with path.open("rb") as stream:
        header = stream.read(84)
    count = int.from_bytes(header[80:84], "little") if len(header) == 84 else -1
    return count > 0 and path.stat().st_size == 84 + 50 * count


def _mujoco_mesh(path: Path) -> Path:
    """A path MuJoCo can read for ``path``: the file itself, or a binary STL converted once into the cache."""
    suffix = path.suffix.lower()
    if suffix in _MUJOCO_MESHES and (suffix != ".stl" or _binary_stl(path)):
        return path.resolve()
    stat = path.stat()
    key = hashlib.sha256(f"{path.resolve()}\0{stat.st_size}\0{stat.st_mtime_ns}".encode()).hexdigest()[:24]
    converted = mesh_cache() / f"{key}.stl"
    if not converted.is_file():
        import trimesh

        loaded = trimesh.load(str(path), force="mesh")
        if not isinstance(loaded, trimesh.Trimesh) or len(loaded.faces) == 0:
            raise CompileFailed(f"{path}: no triangles MuJoCo could use")
        converted.parent.mkdir(parents=True, exist_ok=True)
        temporary = converted.with_name(f".{converted.name}.{os.getpid()}.tmp")
        loaded.export(str(temporary), file_type="stl")
        os.replace(temporary, converted)
    return converted


def _prepared_urdf(source: UrdfSource, notes: list[str]) -> etree._Element:
    root = copy.deepcopy(source.root)
    for link in root.findall("link"):
        for visual in link.findall("visual"):  # only collisions act; visuals would cost mesh loads
            link.remove(visual)
        for collision in link.findall("collision"):
            mesh = collision.find("geometry/mesh")
            if mesh is None:
                continue
            path = resolve_mesh(mesh.get("filename", ""), source)
            try:
                # is_file: a regular file only (a FIFO would block the read; the meshes check names it)
                usable = path is not None and path.is_file() and mesh_size_problem(path) is None  # meshes names it
                mesh.set("filename", str(_mujoco_mesh(path)) if usable else "")
            except (OSError, ValueError, CompileFailed):
                mesh.set("filename", "")
            if not mesh.get("filename"):
                link.remove(collision)
                notes.append(f"link '{link.get('name')}': a collision mesh left out (see meshes)")
    movable = {j.get("name") for j in root.findall("joint") if j.get("type") in MOVABLE}
    for joint in root.findall("joint"):
        mimic = joint.find("mimic")
        if mimic is not None and mimic.get("joint") not in movable:
            joint.remove(mimic)
            notes.append(f"joint '{joint.get('name')}': its <mimic> left out (see mimic)")
    for old in root.findall("mujoco"):
        root.remove(old)
    mujoco_element = etree.SubElement(root, "mujoco")
    # Every link its own body (fusestatic off), so that MuJoCo's parent-child contact filter excludes exactly the
    # pairs a URDF joint connects, the root link and its children included, as Gazebo and pybullet do.
    etree.SubElement(
        mujoco_element,
        "compiler",
        strippath="false",
        discardvisual="true",
        balanceinertia="false",
        fusestatic="false",
    )
    return root


def _spec(root: etree._Element, lenient: bool):  # type: ignore[no-untyped-def]
    import mujoco

    if lenient:
        # MuJoCo refuses moving bodies without mass, inertias that are not positive definite or break the triangle
        # inequality (each an inertials finding), and meshes too thin for a volume, whose inertia the URDF's
        # <inertial> overrides anyway: bound, project and balance them, and take meshes as shells.
        root.find("mujoco/compiler").attrib.update(
            {"boundmass": "1e-6", "boundinertia": "1e-12", "balanceinertia": "true"}
        )
        for inertia in root.iterfind("link/inertial/inertia"):
            _positive_definite(inertia)
    spec = mujoco.MjSpec.from_string(etree.tostring(root).decode())
    if lenient:
        for mesh in spec.meshes:
            mesh.inertia = mujoco.mjtMeshInertia.mjMESH_INERTIA_SHELL
    spec.compile()
    return spec


def _positive_definite(inertia: etree._Element) -> None:
    keys = ("ixx", "ixy", "ixz", "iyy", "iyz", "izz")
    try:
        ixx, ixy, ixz, iyy, iyz, izz = (float(inertia.get(k, "0")) for k in keys)
    except ValueError:
        return
    matrix = np.array([[ixx, ixy, ixz], [ixy, iyy, iyz], [ixz, iyz, izz]])
    if not np.all(np.isfinite(matrix)):
        return
    values, vectors = np.linalg.eigh(matrix)
    if values.min() > 0:
        return
    fixed = vectors @ np.diag(np.maximum(values, 1e-12)) @ vectors.T
    for key, (i, j) in zip(keys, ((0, 0), (0, 1), (0, 2), (1, 1), (1, 2), (2, 2))):
        inertia.set(key, repr(float(fixed[i, j])))


def compile_urdf(
    source: UrdfSource, pose: dict[str, float] | None = None, joints: Mapping[str, Any] | None = None
) -> Compiled:
    """The URDF compiled by MuJoCo's importer with its servos; with ``pose`` (the settings' rest pose), a keyframe
    'rest' there, the servos aimed at it, which the checks then take as the pose the file states; ``joints`` (the
    settings' JointSettings by name) may rate a joint's effort over its <limit effort>."""
    import mujoco

    notes: list[str] = []
    root = _prepared_urdf(source, notes)
    joints = joints or {}
    _efforts_over(root, joints, source.path)
    with quiet_mujoco() as said:
        try:
            spec = _spec(root, lenient=False)
        except ValueError:
            try:
                spec = _spec(root, lenient=True)
            except ValueError as exc:
                raise _refusal(exc, source, root) from None
            notes.append(
                "simulated with masses below 1e-6 kg and inertias below 1e-12 kg m2 raised to those, inertias that "
                "are not positive definite or break the triangle inequality made so, meshes taken as shells "
                "(see inertials)"
            )
        spec.option.integrator = mujoco.mjtIntegrator.mjINT_IMPLICITFAST
        # A <mimic> is a rigid coupling. MuJoCo's default equality is soft: a 0.02 s time constant sags 0.03 to
        # 0.06 rad on a gripper's finger under gravity, and an impedance of 0.9 to 0.95 lets a follower's own
        # damping drag it (svh_right's j4: 0.08 N m s on 1.9e-6 kg m2, 0.09 rad behind). The stiffest stable time
        # constant is twice the timestep (MuJoCo's guidance for solref), the impedance 0.99 to 0.999 (0.010 rad).
        for equality in spec.equalities:
            equality.solref = [2 * spec.option.timestep, 1.0]
            equality.solimp = [0.99, 0.999, 0.001, 0.5, 2.0]
        _exclude_joined(spec, root)
        efforts = _servos(spec, root)
        model = spec.compile()
        overlapping = always_touching(model, OVERLAP_SAMPLES)
        if overlapping:
            _exclude(spec, overlapping)
            model = spec.compile()
        if pose:
            _add_rest(spec, model, pose, source.path)
            model = spec.compile()
    notes += [f"MuJoCo: {' '.join(line.split())}" for line in said]

    def where(tag: str, name: str) -> tuple[str, int | None]:
        """tag body: the <link>; joint: the <joint>; rating: the joint's <limit> (its effort)."""
        if tag == "timestep":  # a URDF states none: MuJoCo's default, at the <robot>
            return source.where(source.root)
        path = {"body": f"link[@name='{name}']", "rating": f"joint[@name='{name}']/limit"}
        element = source.root.find(path.get(tag, f"joint[@name='{name}']"))
        if element is None and tag == "rating":
            element = source.root.find(f"joint[@name='{name}']")
        return source.where(element) if element is not None else (str(source.path), None)

    rated = {model.joint(name).id: effort for name, effort in efforts.items()}
    velocity = {model.joint(name).id: speed for name, speed in _velocities(root).items() if name in efforts}
    return Compiled(model, where, rated, notes, "urdf", tuple(sorted(overlapping)), velocity, joints=joints)


def _efforts_over(root: etree._Element, joints: Mapping[str, Any], path: Path) -> None:
    """The settings' efforts written into the prepared copy's <limit>s; a joint the model lacks is an error."""
    for name, quirks in joints.items():
        joint = next((j for j in root.iterfind("joint") if j.get("name") == name), None)
        if joint is None:
            raise unknown_joint(path, name)
        if quirks.effort is None:
            continue
        if joint.find("limit") is None:
            raise SvhdescError(
                f"{path}: the settings rate joint '{name}' at effort {quirks.effort:g}; it has no <limit>"
            )
        joint.find("limit").set("effort", repr(quirks.effort))


def unknown_joint(path: Path, name: str, key: str = "joints") -> SvhdescError:
    return SvhdescError(f"{path}: the settings' {key} names joint '{name}', which the model does not have")


def _velocities(root: etree._Element) -> dict[str, float]:
    found = {}
    for limit in root.iterfind("joint/limit"):
        try:
            speed = float(limit.get("velocity", "nan"))
        except ValueError:
            continue
        if np.isfinite(speed) and speed > 0:
            found[limit.getparent().get("name", "")] = speed
    return found


@contextmanager
def quiet_mujoco():  # type: ignore[no-untyped-def]
    """MuJoCo's warnings collected instead of printed: a validator's output is its report."""
    import mujoco

    said: list[str] = []
    previous = mujoco.get_mju_user_warning()
    mujoco.set_mju_user_warning(said.append)
    try:
        yield said
    finally:
        mujoco.set_mju_user_warning(previous)


def _add_rest(spec, model, pose: dict[str, float], path: Path) -> None:  # type: ignore[no-untyped-def]
    qpos = model.qpos0.copy()
    for name, value in pose.items():
        try:
            joint = model.joint(name)
        except KeyError:
            raise unknown_joint(path, name, "pose") from None
        qpos[model.jnt_qposadr[joint.id]] = value
    ctrl = [qpos[model.jnt_qposadr[model.actuator_trnid[i, 0]]] for i in range(model.nu)]
    spec.add_key(name="rest", qpos=qpos.tolist(), ctrl=ctrl)


def _exclude(spec, pairs) -> None:  # type: ignore[no-untyped-def]
    for a, b in pairs:
        if "world" not in (a, b):
            exclude = spec.add_exclude()
            exclude.bodyname1, exclude.bodyname2 = a, b


def _exclude_joined(spec, root: etree._Element) -> None:  # type: ignore[no-untyped-def]
    """No contact between two links a joint connects: MuJoCo's own parent filter spares a body whose parent is
    welded to the world (a fixed base's first link), which no URDF simulator lets collide with its base."""
    bodies = {body.name for body in spec.bodies}
    for joint in root.findall("joint"):
        parent, child = joint.find("parent"), joint.find("child")
        names = (parent.get("link") if parent is not None else None, child.get("link") if child is not None else None)
        if all(name in bodies for name in names):
            exclude = spec.add_exclude()
            exclude.bodyname1, exclude.bodyname2 = names


def _servos(spec, root: etree._Element) -> dict[str, float]:  # type: ignore[no-untyped-def]
    """A position servo on every movable joint that no <mimic> drives, its force the joint's rated effort; the
    efforts of every movable joint that states one."""
    import mujoco

    model = spec.compile()
    mobility = _mobility(model)
    efforts: dict[str, float] = {}
    for joint in root.findall("joint"):
        limit = joint.find("limit")
        name = joint.get("name", "")
        try:
            effort = float(limit.get("effort", "nan")) if limit is not None else float("nan")
        except ValueError:
            effort = float("nan")
        if joint.get("type") not in MOVABLE or not np.isfinite(effort) or effort <= 0:
            continue
        efforts[name] = effort
        if joint.find("mimic") is not None:
            continue
        index = model.joint(name).id
        lo, hi = model.jnt_range[index] if model.jnt_limited[index] else (-np.pi, np.pi)
        error = SATURATION_ERROR * (1.0 if joint.get("type") != "prismatic" else max(hi - lo, 1e-3))
        # Stable at the timestep: kp (M^-1)_ii dt^2 well below the integrator's limit (omega dt = 0.2), with the
        # joint's mobility (M^-1)_ii, not 1/M_ii: in a chain the other joints' give way makes it far larger (a
        # human's shoulder sized on 1/M_ii diverged under Menagerie's random controls).
        kp = min(effort / error, (0.2 / model.opt.timestep) ** 2 / mobility[model.jnt_dofadr[index]])
        servo = spec.add_actuator(name=f"{name}_servo", target=name, trntype=mujoco.mjtTrn.mjTRN_JOINT)
        servo.set_to_position(kp=kp, dampratio=1.0)
        servo.ctrllimited = 1
        servo.ctrlrange = [lo, hi]
        servo.forcelimited = 1
        servo.forcerange = [-effort, effort]
    return efforts


def _mobility(model) -> np.ndarray:  # type: ignore[no-untyped-def]
    """Each dof's (M^-1)_ii, the largest over the rest pose and 8 poses spread over the ranges."""
    import mujoco

    from svhdesc.validate.poses import set_pose

    data = mujoco.MjData(model)
    worst = np.zeros(model.nv)
    for sample in range(9):
        if sample:
            set_pose(model, data, sample)
        mujoco.mj_forward(model, data)
        full = np.zeros((model.nv, model.nv))
        mujoco.mj_fullM(model, data, full)  # MuJoCo 4's signature (model, data, dst)
        full[np.diag_indices(model.nv)] += model.dof_armature
        try:
            inverse = np.diag(np.linalg.inv(full))
        except np.linalg.LinAlgError:
            inverse = 1.0 / np.maximum(np.diag(full), 1e-12)
        worst = np.maximum(worst, inverse)
    return worst


def mjcf_compiled(  # type: ignore[no-untyped-def]
    model,
    where: Callable[[str, str], tuple[str, int | None]],
    keyframe: str | None = None,
    joints: Mapping[str, Any] | None = None,
    path: Path | None = None,
) -> Compiled:
    """An MJCF's model as it compiled, its actuators' force bounds the joints' ratings (a joint's settings' effort
    over them), resting in the settings' ``keyframe`` (else keyframe 0)."""
    import mujoco

    shown, joints, rated = path or Path(where("model", "")[0]), joints or {}, _actuator_bounds(model)
    key = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_KEY, keyframe) if keyframe is not None else 0
    if key < 0:
        names = ", ".join(f"'{model.key(k).name}'" for k in range(model.nkey)) or "none"
        raise SvhdescError(f"{shown}: the settings name keyframe '{keyframe}', which the model does not have ({names})")
    for name, quirks in joints.items():
        joint = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, name)
        if joint < 0:
            raise unknown_joint(shown, name)
        if quirks.effort is not None:
            rated[joint] = quirks.effort
    return Compiled(model, where, rated, [], "mjcf", key=key, joints=joints)


def _actuator_bounds(model) -> dict[int, float]:  # type: ignore[no-untyped-def]
    """Each actuated joint's force bound: forcerange x gear, a motor's ctrlrange x gain x gear, or the joint's own
    actuator force range; a position servo without a bound is left out (it holds anything)."""
    import mujoco

    bounds: dict[int, float] = {}
    for i in range(model.nu):
        if model.actuator_trntype[i] != mujoco.mjtTrn.mjTRN_JOINT:
            continue
        joint, gear = int(model.actuator_trnid[i, 0]), abs(float(model.actuator_gear[i, 0]))
        if model.actuator_forcelimited[i]:
            bound = float(np.max(np.abs(model.actuator_forcerange[i]))) * gear
        elif model.actuator_biastype[i] == mujoco.mjtBias.mjBIAS_NONE and model.actuator_ctrllimited[i]:
            bound = float(np.max(np.abs(model.actuator_ctrlrange[i]))) * abs(model.actuator_gainprm[i, 0]) * gear
        else:
            continue
        bounds[joint] = bounds.get(joint, 0.0) + bound
    for joint in range(model.njnt):
        if model.jnt_actfrclimited[joint]:
            limit = float(np.max(np.abs(model.jnt_actfrcrange[joint])))
            bounds[joint] = min(bounds.get(joint, limit), limit)
    return bounds
