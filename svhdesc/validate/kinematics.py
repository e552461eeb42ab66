"""Check 4: every URDF link frame (yourdfpy FK) and the MJCF body of the same name agree in random poses."""

from __future__ import annotations

import io
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from lxml import etree

from svhdesc.model import actuated_joints, couplings, scalar_joints
from svhdesc.polynomial import polyval
from svhdesc.validate.options import Options
from svhdesc.validate.pair import ModelPair
from svhdesc.validate.report import Check, fmt, not_run, verdict

POS_TOL = 1e-6  # m
ROT_TOL = 1e-6  # rad


def rotation_angle(a: np.ndarray, b: np.ndarray) -> float:
    """Angle of a^T b, from the chord ||a - b||_F = 2 sqrt(2) sin(angle / 2): exact near zero, unlike arccos."""
    chord = float(np.linalg.norm(a - b)) / (2.0 * np.sqrt(2.0))
    return 2.0 * float(np.arcsin(min(1.0, chord)))


def sample_configurations(model: Any, count: int, rng: np.random.Generator) -> list[dict[str, float]]:
    """Actuated joints uniform over the commanded range; coupled joints from their polynomial;
    any other hinge/slide uniform over its range (or +-pi when unlimited)."""
    actuated = actuated_joints(model)
    equalities = couplings(model)
    coupled = {e.joint for e in equalities}
    scalar = scalar_joints(model)
    samples = []
    for _ in range(count):
        q: dict[str, float] = {}
        for j in scalar:
            name = model.joint(j).name
            if name in coupled:
                continue
            if name in actuated and np.isfinite(actuated[name]).all():
                low, high = actuated[name]
            elif model.jnt_limited[j]:
                low, high = model.jnt_range[j]
            else:
                low, high = -np.pi, np.pi
            q[name] = float(rng.uniform(low, high))
        for e in equalities:
            q[e.joint] = float(polyval(e.coeffs, q.get(e.leader, 0.0)))
        samples.append(q)
    return samples


def _unmimicked_urdf(path: Any) -> Any:
    """yourdfpy with the <mimic> tags removed, so that every joint is set explicitly: the coupling itself is
    the business of coupling_spec, this check compares pure geometry (origins and axes)."""
    import yourdfpy

    tree = etree.parse(str(path))
    for mimic in list(tree.iter("mimic")):
        mimic.getparent().remove(mimic)
    return yourdfpy.URDF.load(io.BytesIO(etree.tostring(tree)), load_meshes=False, build_collision_scene_graph=False)


def check_kinematics(pair: ModelPair, options: Options) -> list[Check]:
    bound = f"<= {POS_TOL:g} m, {ROT_TOL:g} rad"
    robot = _comparable_urdf(pair, bound)
    if isinstance(robot, Check):
        return [robot]
    model = pair.model
    root = robot.base_link
    body_ids = {model.body(b).name: b for b in range(model.nbody)}
    problems = _joint_name_problems(model, robot)
    links = [name for name in robot.link_map if name in body_ids or name == root]
    missing_bodies = [name for name in robot.link_map if name not in body_ids and name != root]
    if missing_bodies:
        problems.append(f"URDF links without an MJCF body: {missing_bodies}")
    samples = sample_configurations(model, options.samples, np.random.default_rng(options.seed))
    errors = _compare_frames(model, robot, links, body_ids, samples)
    if errors.bad_links:
        # The first link (in tree order) that disagrees is where the two files part ways.
        bad_links = errors.bad_links
        listed = ", ".join(f"{k} ({v[0]:.3g} m, {v[1]:.3g} rad)" for k, v in list(bad_links.items())[:4])
        problems.append(f"{len(bad_links)} link(s) disagree: {listed}{', ...' if len(bad_links) > 4 else ''}")
    worst_pos, worst_rot = errors.worst_pos, errors.worst_rot
    detail = "; ".join(problems) or (
        f"{options.samples} configurations x {len(links)} links; worst position "
        f"{worst_pos[1] or '-'}, worst rotation {worst_rot[1] or '-'}"
    )
    return [
        Check(
            "kinematics",
            verdict(not problems),
            f"{fmt(worst_pos[0])} m, {fmt(worst_rot[0])} rad",
            bound,
            detail,
            {
                "samples": options.samples,
                "links": len(links),
                "max_position_error_m": worst_pos[0],
                "max_rotation_error_rad": worst_rot[0],
                "disagreeing_links": errors.bad_links,
                "problems": problems,
            },
        )
    ]


def _comparable_urdf(pair: ModelPair, bound: str) -> Any:
    """The URDF as yourdfpy loads it without mimics; or the not-run check saying why there is nothing to compare."""
    if pair.model is None:
        return not_run("kinematics", "the MJCF does not compile", bound)
    if pair.urdf is None:
        return not_run("kinematics", f"the URDF cannot be read ({pair.urdf_error})", bound)
    try:
        return _unmimicked_urdf(pair.urdf_path)
    except ImportError:
        return not_run("kinematics", "yourdfpy is not installed", bound, missing_tool="pip install yourdfpy")
    except Exception as exc:  # a URDF yourdfpy cannot load fails the yourdfpy check; here we cannot compare
        return not_run("kinematics", f"yourdfpy cannot load the URDF: {exc}", bound)


def _joint_name_problems(model: Any, robot: Any) -> list[str]:
    """Joints one file has and the other lacks."""
    problems = []
    mj_joints = {model.joint(j).name for j in range(model.njnt)}
    urdf_joints = set(robot.actuated_joint_names)
    if urdf_joints - mj_joints:
        problems.append(f"URDF joints missing in the MJCF: {sorted(urdf_joints - mj_joints)}")
    if mj_joints - urdf_joints:
        problems.append(f"MJCF joints missing in the URDF: {sorted(mj_joints - urdf_joints)}")
    return problems


@dataclass
class _FrameErrors:
    """The worst position and rotation error (value, link, sample) and each link over the tolerances."""

    worst_pos: tuple[float, str, int] = (0.0, "", -1)
    worst_rot: tuple[float, str, int] = (0.0, "", -1)
    bad_links: dict[str, tuple[float, float]] = field(default_factory=dict)

    def add(self, link: str, index: int, pos_err: float, rot_err: float) -> None:
        if pos_err > self.worst_pos[0]:
            self.worst_pos = (pos_err, link, index)
        if rot_err > self.worst_rot[0]:
            self.worst_rot = (rot_err, link, index)
        if pos_err > POS_TOL or rot_err > ROT_TOL:
            old = self.bad_links.get(link, (0.0, 0.0))
            self.bad_links[link] = (max(old[0], pos_err), max(old[1], rot_err))


def _compare_frames(
    model: Any, robot: Any, links: list[str], body_ids: dict[str, int], samples: list[dict[str, float]]
) -> _FrameErrors:
    """Each link's frame relative to the root, by yourdfpy and by MuJoCo, in every sampled configuration."""
    import mujoco

    data = mujoco.MjData(model)
    root = robot.base_link
    # The URDF root is the MJCF world when it is the geometry-less 'world' link, else a body at the origin.
    root_body = body_ids.get(root, 0)
    errors = _FrameErrors()
    for index, q in enumerate(samples):
        data.qpos[:] = model.qpos0
        for name, value in q.items():
            data.qpos[model.jnt_qposadr[model.joint(name).id]] = value
        mujoco.mj_kinematics(model, data)
        robot.update_cfg(np.array([q.get(name, 0.0) for name in robot.actuated_joint_names]))
        root_rot = data.xmat[root_body].reshape(3, 3)
        root_pos = data.xpos[root_body]
        for link in links:
            urdf_pose = robot.get_transform(link, root)
            body = body_ids.get(link, root_body)
            mj_rot = root_rot.T @ data.xmat[body].reshape(3, 3)
            mj_pos = root_rot.T @ (data.xpos[body] - root_pos)
            errors.add(
                link, index, float(np.linalg.norm(urdf_pose[:3, 3] - mj_pos)), rotation_angle(urdf_pose[:3, :3], mj_rot)
            )
    return errors
