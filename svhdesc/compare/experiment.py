"""The thesis' chapter-5 contact experiment, defined once for every engine (and for ``svhdesc validate``).

The robot is driven from keyframe ``home`` to ``test`` by position servos (targets ramped over RAMP s),
and the index fingertip presses a fixed box whose face sits DEPTH inside the fingertip's collision
geometry in the ``test`` pose. After SETTLE s the joints are sampled at a fixed rate for RECORD s; the
stability measure is the mean absolute deviation of each joint from its WINDOW-sample running average
(thesis eq. 5.1), the window centred on the sample (the thesis' reading) or trailing it. ``Conditions``
switches to the thesis' own conditions; ``deviations`` lists every way a run differs from the thesis.

Where the surface goes is worked out once, with MuJoCo's kinematics on the MJCF: the URDF and the MJCF
are generated from the same IR and agree to 1e-15 m (checked by ``validate``), so the box placed here is
the same box in every engine's world frame.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from svhdesc.model import Coupling, couplings, scalar_joints
from svhdesc.polynomial import polyval

RAMP = 1.0  # s, home -> test control ramp
SETTLE = 2.0  # s after the ramp before recording
RECORD = 2.0  # s recorded
DEPTH = 0.0025  # m the surface sits inside the fingertip in the test pose
THICKNESS = 0.01  # m half thickness of the box
WINDOW = 10  # samples in the running average of eq. 5.1
PAD_HALF_WIDTH = 0.004  # m: a pad-side surface covers the fingertip pad only
TABLE_HALF_WIDTH = 0.05  # m: an approached surface is a small table the tip may slide on
MOVES = 0.01  # m: a fingertip that travels farther than this from home to test approaches the surface
SURFACE = "svhdesc_contact_surface"


class SetupError(Exception):
    """The model lacks what the experiment needs (touch sensor, keyframes, fingertip geometry)."""


WINDOWS = ("centred", "trailing")  # where sample i sits in its running-average window (``mad``)


def window_span(window: int, placement: str) -> tuple[int, int]:
    """(samples before i, samples after i) in the running average of sample i.

    centred: "the running average around the i-th sample" (eq. 5.1) as MATLAB's ``movmean``, the
    thesis' tool, takes it: an even window holds window/2 samples before i and window/2 - 1 after.
    trailing: the window - 1 samples before i."""
    if placement == "centred":
        return window // 2, window - 1 - window // 2
    if placement == "trailing":
        return window - 1, 0
    raise ValueError(f"window placement must be one of {', '.join(WINDOWS)}, not {placement!r}")


def mad(series: np.ndarray, window: int = WINDOW, placement: str = "centred") -> np.ndarray:
    """Thesis eq. 5.1 per column: mean |x_i - xbar_i|, xbar_i the mean of the window around sample i.

    Only samples with a full window count (N = len - window + 1). Each window is summed exactly
    (``math.fsum``) after subtracting the column's first sample, so a trace that holds one value gives
    exactly 0 and no rounding floor of a cumulative sum (about 1e-13 rad at 2000 samples) remains.
    A 1-D series gives a scalar-shaped array."""
    series = np.asarray(series, dtype=float)
    flat = series.ndim == 1
    if flat:
        series = series[:, None]
    if len(series) < window:
        raise ValueError(f"eq. 5.1 needs at least {window} samples, got {len(series)}")
    before, _ = window_span(window, placement)
    # Near-constant traces: x - x_0 is exact (Sterbenz), and the sums below see only the deviations.
    shifted = series - series[:1]
    count = len(series) - window + 1
    result = np.empty(series.shape[1])
    for column in range(series.shape[1]):
        values = shifted[:, column].tolist()
        deviations = [
            abs(values[start + before] - math.fsum(values[start : start + window]) / window) for start in range(count)
        ]
        result[column] = math.fsum(deviations) / count
    return result[0] if flat else result


def moving_mean(series: np.ndarray, window: int) -> np.ndarray:
    """Trailing moving mean (shorter windows at the start), for the force plots (thesis Fig. 5.16)."""
    series = np.asarray(series, dtype=float)
    cumulative = np.concatenate([[0.0], np.cumsum(series)])
    index = np.arange(1, len(series) + 1)
    start = np.maximum(index - window, 0)
    return (cumulative[index] - cumulative[start]) / (index - start)


def ramp(start: np.ndarray, goal: np.ndarray, step: int, dt: float, duration: float = RAMP) -> np.ndarray:
    """Servo targets at step ``step`` (the step about to be taken): linear home -> test over ``duration`` s,
    then held."""
    return start + (goal - start) * min(1.0, step * dt / duration)


def schedule(dt: float, duration: float | None = None) -> tuple[int, int, float]:
    """(total steps, first recorded step, ramp time) for RAMP + SETTLE + RECORD s, or ``duration`` s.

    A shorter (or longer) duration scales all three phases alike, so a quick run still ramps, settles
    and records in the same proportions."""
    full = RAMP + SETTLE + RECORD
    scale = 1.0 if duration is None else duration / full
    total = int(round(full * scale / dt))
    return total, total - int(round(RECORD * scale / dt)), RAMP * scale


# Thesis Table 4.1, "test" pose of the arm as printed. The model's keyframe has shoulder_lift, wrist_1 and
# wrist_2 with the opposite sign (the hand then reaches forward and down onto the surface).
TABLE_4_1_TEST_ARM = {
    "shoulder_pan_joint": 1.5707,
    "shoulder_lift_joint": 0.4014,
    "elbow_joint": 0.9250,
    "wrist_1_joint": 2.3387,
    "wrist_2_joint": 1.5794,
    "wrist_3_joint": 0.0,
}
THESIS_LINK_MASS = 0.01  # kg, every hand link of the thesis' models
THESIS_SAMPLE_DT = 0.02  # s: joint_state_controller publish_rate 50 (thesis Sec. 4.1.3)
SAMPLE_DT = 0.001  # s: this project's sampling, every physics step


@dataclass(frozen=True)
class Conditions:
    """The thesis' conditions (``--thesis-setup``) or this project's choices, and the eq. 5.1 window."""

    thesis: bool = False
    window: str = "centred"

    @property
    def sample_dt(self) -> float:
        return THESIS_SAMPLE_DT if self.thesis else SAMPLE_DT

    @property
    def link_mass(self) -> float | None:
        return THESIS_LINK_MASS if self.thesis else None

    @property
    def force(self) -> str:
        """'vertical': the z component of the contact force (thesis Fig. 5.16); 'normal': along the contact normal."""
        return "vertical" if self.thesis else "normal"

    @property
    def test_pose(self) -> dict[str, float]:
        return dict(TABLE_4_1_TEST_ARM) if self.thesis else {}

    def describe(self) -> dict[str, Any]:
        before, after = window_span(WINDOW, self.window)
        return {
            "thesis_setup": self.thesis,
            "mad_window": f"{WINDOW} samples, {self.window} ({before} before, {after} after each sample)",
            "sample_rate_hz": round(1.0 / self.sample_dt),
            "hand_link_mass_kg": self.link_mass if self.link_mass is not None else "physical (the mass budget)",
            "force": self.force,
            "test_pose": "thesis Table 4.1 as printed" if self.thesis else "the model's test keyframe",
            "deviations": deviations(self),
        }


def deviations(conditions: Conditions) -> list[dict[str, str]]:
    """Every way this run differs from the thesis' chapter-5 experiment, with the reason."""
    items = [
        {
            "what": "surface",
            "thesis": "a surface in the Gazebo world, placement not given",
            "here": f"a box whose face sits {DEPTH * 1e3:g} mm inside the fingertip in the test pose, square to "
            "the fingertip's approach direction (its tilt from horizontal: surface_tilt_deg)",
            "why": "the thesis gives no position; a fixed overlap makes every engine press the same amount",
        },
        {
            "what": "timing",
            "thesis": "not given",
            "here": f"ramp {RAMP:g} s home -> test, settle {SETTLE:g} s, record {RECORD:g} s",
            "why": "the thesis records 'when the index finger touches the surface'",
        },
        {
            "what": "servos",
            "thesis": "Gazebo's gazebo_ros_control; its controller configuration (pid_gains) not given",
            "here": "ode: gazebo_ros_control as the generated ros_controllers.yaml configures it (no pid_gains: "
            "POSITION, Joint::SetPosition every step, fmax at the URDF effort); the other engines: position "
            "servos with the model's kp and kv",
            "why": "the thesis gives no gains; the generated files are what a Gazebo run of this model uses",
        },
    ]
    if not conditions.thesis:
        items += [
            {
                "what": "test pose",
                "thesis": "Table 4.1: shoulder_lift +0.4014, wrist_1 +2.3387, wrist_2 +1.5794",
                "here": "keyframe test: shoulder_lift -0.4014, wrist_1 -2.3387, wrist_2 -1.5794",
                "why": "with the printed signs the fingertip approaches sideways and a surface placed in its "
                "path also touches the index finger's other links (run --thesis-setup: the experiment block "
                "gives the direction and the other bodies touching); with the keyframe's it comes down from above",
            },
            {
                "what": "link masses",
                "thesis": f"{THESIS_LINK_MASS:g} kg per hand link",
                "here": "the mass budget: 1.3 kg hand, UR5 masses",
                "why": "the real hand weighs 1.3 kg",
            },
            {
                "what": "sampling",
                "thesis": "joint states at 50 Hz (joint_state_controller)",
                "here": f"{1 / SAMPLE_DT:g} Hz, every physics step",
                "why": "eq. 5.1 over every step sees the fastest oscillation an engine produces",
            },
            {
                "what": "force",
                "thesis": "vertical component of the contact force",
                "here": "force along the contact normal",
                "why": "the normal force is what presses; the surface is tilted, so the vertical part is smaller",
            },
        ]
    return items


@dataclass(frozen=True)
class Surface:
    """The fixed box, in world coordinates: its +z face (local) is the surface the fingertip presses."""

    position: np.ndarray
    quat: np.ndarray  # w x y z
    rotation: np.ndarray  # columns: box x, y, z axes
    half_size: tuple[float, float, float]
    normal: np.ndarray  # unit vector from the fingertip towards the surface
    direction_from: str


@dataclass
class Setup:
    """Everything an engine needs to run the experiment, by joint and link name."""

    joints: list[str]  # every scalar joint, MJCF order
    actuated: list[str]  # joints with a position servo, actuator order
    home_ctrl: np.ndarray  # servo targets per actuated joint
    test_ctrl: np.ndarray
    home_qpos: np.ndarray  # per joint
    test_qpos: np.ndarray
    couplings: list[Coupling]
    fingertip: str  # body / link name
    tip_test_position: np.ndarray  # fingertip frame origin in the test keyframe (world)
    surface: Surface
    friction: float  # fingertip-surface sliding friction, as MuJoCo combines it (max of the two)
    other_bodies_touching_at_test: list[str] = field(default_factory=list)

    def coupling_residual(self, qpos: np.ndarray) -> np.ndarray:
        """|q_joint - f(q_leader)| per sample (rows) and coupling (columns)."""
        qpos = np.atleast_2d(qpos)
        index = {name: i for i, name in enumerate(self.joints)}
        columns = [
            np.abs(qpos[:, index[c.joint]] - polyval(c.coeffs, qpos[:, index[c.leader]])) for c in self.couplings
        ]
        return np.column_stack(columns) if columns else np.zeros((len(qpos), 0))

    def description(self, dt: float) -> dict[str, Any]:
        return {
            "fingertip": self.fingertip,
            "direction": self.surface.normal.tolist(),
            "direction_from": self.surface.direction_from,
            "surface_pos": self.surface.position.tolist(),
            "surface_half_size": list(self.surface.half_size),
            "surface_tilt_deg": float(np.degrees(np.arccos(min(1.0, abs(float(self.surface.normal[2])))))),
            "depth_m": DEPTH,
            "other_bodies_touching_at_test": self.other_bodies_touching_at_test,
            "ramp_s": RAMP,
            "settle_s": SETTLE,
            "record_s": RECORD,
            "timestep": dt,
        }


# --- MuJoCo kinematics: where the surface goes -----------------------------------------------------------


def touch_site(model: Any) -> int | None:
    import mujoco

    for sensor in range(model.nsensor):
        if int(model.sensor_type[sensor]) == int(mujoco.mjtSensor.mjSENS_TOUCH):
            return int(model.sensor_objid[sensor])
    return None


def keyframes(model: Any) -> tuple[int, int]:
    import mujoco

    home = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_KEY, "home")
    test = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_KEY, "test")
    if home < 0 or test < 0:
        raise SetupError("the MJCF lacks keyframe 'home' or 'test'")
    return home, test


def fingertip(model: Any) -> tuple[int, list[int]]:
    """The body carrying the touch sensor, and its collision geoms."""
    site = touch_site(model)
    if site is None:
        raise SetupError("the MJCF has no touch sensor to find the fingertip by")
    tip = int(model.site_bodyid[site])
    geoms = [
        g
        for g in range(model.ngeom)
        if model.geom_bodyid[g] == tip and (model.geom_contype[g] or model.geom_conaffinity[g])
    ]
    if not geoms:
        raise SetupError(f"fingertip body {model.body(tip).name} has no collision geometry")
    return tip, geoms


def _geom_points(model: Any, data: Any, geom: int) -> np.ndarray:
    """World points bounding a geom: mesh vertices, else the corners of its local bounding box."""
    import mujoco

    rotation = data.geom_xmat[geom].reshape(3, 3)
    if int(model.geom_type[geom]) == int(mujoco.mjtGeom.mjGEOM_MESH) and model.geom_dataid[geom] >= 0:
        mesh = model.geom_dataid[geom]
        start, count = model.mesh_vertadr[mesh], model.mesh_vertnum[mesh]
        local = model.mesh_vert[start : start + count].astype(float)
    else:
        centre, half = model.geom_aabb[geom, :3], model.geom_aabb[geom, 3:]
        corners = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)])
        local = centre + corners * half
    return data.geom_xpos[geom] + local @ rotation.T


def _tip_points(model: Any, data: Any, geoms: list[int]) -> np.ndarray:
    return np.vstack([_geom_points(model, data, g) for g in geoms])


def _leading_channel(model: Any, body: int) -> tuple[int, list[tuple[int, tuple[float, ...]]]]:
    """The channel joint nearest above the body (a coupled joint leads to its channel), and its followers."""
    equalities = couplings(model)
    follows = {model.joint(e.joint).id: model.joint(e.leader).id for e in equalities}
    while body > 0 and model.body_jntnum[body] == 0:
        body = model.body_parentid[body]
    joint = int(model.body_jntadr[body]) if body > 0 else -1
    channel = follows.get(joint, joint)
    followers = [(model.joint(e.joint).id, e.coeffs) for e in equalities if model.joint(e.leader).id == channel]
    return channel, followers


def _direction(model: Any, data: Any, tip: int, geoms: list[int], home: int, test: int) -> tuple[np.ndarray, str]:
    """The direction in which the surface lies, seen from the fingertip in the test pose.

    A fingertip that the arm carries from home to test approaches the surface: the direction of that
    final approach (a box on the pad side would be swept through by the hand on its way). A fingertip
    that stays put presses with its pad: the direction it moves when its distal channel flexes."""
    import mujoco

    def points_at(qpos: np.ndarray) -> np.ndarray:
        data.qpos[:] = qpos
        mujoco.mj_kinematics(model, data)
        return _tip_points(model, data, geoms)

    q_home, q_test = model.key_qpos[home].copy(), model.key_qpos[test].copy()
    at_test = points_at(q_test)
    travel = float(np.linalg.norm(at_test.mean(axis=0) - points_at(q_home).mean(axis=0)))
    if travel > MOVES:
        before = points_at(q_home + 0.9 * (q_test - q_home))
        direction = at_test.mean(axis=0) - before.mean(axis=0)
        how = f"approach direction (the fingertip travels {travel * 100:.1f} cm from home to test)"
    else:
        channel, followers = _leading_channel(model, tip)
        if channel < 0:
            raise SetupError("no joint above the fingertip to tell where its pad faces")
        q = q_test.copy()
        step = 1e-3
        q[model.jnt_qposadr[channel]] += step
        for joint, coeffs in followers:
            q[model.jnt_qposadr[joint]] = polyval(coeffs, q[model.jnt_qposadr[channel]])
        direction = (points_at(q) - at_test).mean(axis=0)
        how = f"pad direction (motion of the tip when {model.joint(channel).name} flexes)"
    norm = float(np.linalg.norm(direction))
    if norm == 0:
        raise SetupError("the fingertip does not move; cannot tell where to put the surface")
    data.qpos[:] = q_test
    mujoco.mj_kinematics(model, data)
    return direction / norm, how


def _frame(normal: np.ndarray) -> np.ndarray:
    """Rotation whose z axis is ``normal``."""
    helper = np.array([0.0, 0.0, 1.0]) if abs(normal[2]) < 0.9 else np.array([1.0, 0.0, 0.0])
    x = np.cross(helper, normal)
    x /= np.linalg.norm(x)
    return np.column_stack([x, np.cross(normal, x), normal])


def place_surface(model: Any) -> Surface:
    """Where the box goes: DEPTH inside the fingertip's collision geometry in the ``test`` pose."""
    import mujoco

    home, test = keyframes(model)
    tip, geoms = fingertip(model)
    data = mujoco.MjData(model)
    normal, how = _direction(model, data, tip, geoms, home, test)
    points = _tip_points(model, data, geoms)
    heights = points @ normal
    reach = float(heights.max())
    # Centre the surface under the part of the tip that will touch (the points within DEPTH of the
    # extreme): a pad-side surface as wide as the whole tip would also catch the next phalanx.
    centre = points[heights >= reach - max(DEPTH, 1e-4)].mean(axis=0)
    half_width = TABLE_HALF_WIDTH if how.startswith("approach") else PAD_HALF_WIDTH
    rotation = _frame(-normal)  # box z axis points back at the finger: its +z face is the surface
    face = reach - DEPTH
    position = centre + normal * (face + THICKNESS - centre @ normal)
    quat = np.zeros(4)
    mujoco.mju_mat2Quat(quat, rotation.flatten())
    return Surface(position, quat, rotation, (half_width, half_width, THICKNESS), normal, how)


def add_surface(spec: Any, surface: Surface) -> Any:
    """Add the box to an ``mujoco.MjSpec`` as a static world geom; returns the geom spec."""
    import mujoco

    box = spec.worldbody.add_geom()
    box.name = SURFACE
    box.type = mujoco.mjtGeom.mjGEOM_BOX
    box.size = list(surface.half_size)
    box.pos = surface.position
    box.quat = surface.quat
    box.rgba = [0.7, 0.7, 0.7, 1.0]
    box.group = 3  # collision: keep it out of renders
    return box


def bodies_touching(model: Any, data: Any, box: int) -> set[str]:
    """Names of the bodies in contact with geom ``box`` in ``data``'s current contacts."""
    return {
        model.body(model.geom_bodyid[c.geom1 if c.geom2 == box else c.geom2]).name
        for c in data.contact[: data.ncon]
        if box in (c.geom1, c.geom2)
    }


def _override_test(model: Any, test: int, pose: dict[str, float]) -> None:
    """Set joints of keyframe ``test`` (positions and the servo targets of those joints)."""
    for name, value in pose.items():
        joint = model.joint(name)
        model.key_qpos[test][joint.qposadr[0]] = value
        for actuator in range(model.nu):
            if int(model.actuator_trnid[actuator, 0]) == joint.id:
                model.key_ctrl[test][actuator] = value


def define(mjcf_path: Any, test_pose: dict[str, float] | None = None) -> Setup:
    """The experiment for the model in ``mjcf_path``: joints, servo targets, couplings and the surface.

    ``test_pose`` overrides joints of the ``test`` keyframe (``--thesis-setup``: Table 4.1 as printed)."""
    import mujoco

    model = mujoco.MjModel.from_xml_path(str(mjcf_path))
    home, test = keyframes(model)
    _override_test(model, test, test_pose or {})
    tip, _ = fingertip(model)
    surface = place_surface(model)
    joints = scalar_joints(model)
    addresses = model.jnt_qposadr[joints]
    actuated = [model.joint(int(model.actuator_trnid[i, 0])).name for i in range(model.nu)]
    data = mujoco.MjData(model)
    mujoco.mj_resetDataKeyframe(model, data, test)
    mujoco.mj_kinematics(model, data)
    tip_test = data.xpos[tip].copy()

    spec = mujoco.MjSpec.from_file(str(mjcf_path))
    add_surface(spec, surface)
    scene = spec.compile()
    _override_test(scene, test, test_pose or {})
    box = mujoco.mj_name2id(scene, mujoco.mjtObj.mjOBJ_GEOM, SURFACE)
    sdata = mujoco.MjData(scene)
    mujoco.mj_resetDataKeyframe(scene, sdata, test)
    mujoco.mj_forward(scene, sdata)
    others = sorted(bodies_touching(scene, sdata, box) - {scene.body(tip).name})
    tip_friction = max(float(scene.geom_friction[g, 0]) for g in range(scene.ngeom) if scene.geom_bodyid[g] == tip)
    return Setup(
        joints=[model.joint(j).name for j in joints],
        actuated=actuated,
        home_ctrl=model.key_ctrl[home].copy(),
        test_ctrl=model.key_ctrl[test].copy(),
        home_qpos=model.key_qpos[home][addresses].copy(),
        test_qpos=model.key_qpos[test][addresses].copy(),
        couplings=couplings(model),
        fingertip=model.body(tip).name,
        tip_test_position=tip_test,
        surface=surface,
        friction=max(tip_friction, float(scene.geom_friction[box, 0])),
        other_bodies_touching_at_test=others,
    )
