"""THE contract for a built model: what the runtime (loaders, sim, ros, plan, compare, wireloop, batch) and
``svhdesc.validate`` may know of one, read from the built files alone (no compiler import: tests/test_layout.py);
the compiler's exporters share its names.

- the real drivers' interface names, shared with the exporters (ROS/MoveIt config) and the node;
- ``Model``, ``get()``, ``variants()``: a built variant's folder and files, its manifest, its hand (``HandId``: the
  prefix and side the build wrote into the manifest), its meshes as local files, and the ``Configuration`` that
  built it (the config's typed settings, read-only);
- what a compiled MuJoCo model holds: scalar joints, joint actuators, couplings; and a URDF's ``<mimic>`` couplings:
  one ``Coupling`` type, evaluated with ``svhdesc.polynomial.polyval``;
- the batch model's promises (solver options, tolerance, hull size), shared with its exporter;
- the vendor sources as the build reads them (xacro, meshes), for checks against the vendor's own geometry.
"""

from __future__ import annotations

import hashlib
import math
import os
import tempfile
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any, Literal

import numpy as np

from svhdesc.errors import SvhdescError
from svhdesc.paths import default_config, generated_dir, source_root, user_cache
from svhdesc.polynomial import polyval

if TYPE_CHECKING:
    import trimesh
    from lxml import etree

    from svhdesc.ir import Channel

DEFAULT_VARIANT = "ur5_svh_right"

# --- The real drivers' interface names ------------------------------------------------------------------------------
# SCHUNK's ROS 1 SVH driver runs a JointTrajectoryController `<prefix>_controller` over its nine channels;
# ur_robot_driver runs `scaled_pos_joint_traj_controller` over the six arm joints.

# The SVH driver's channels, in its order; the hand's actuated joints are named <prefix>_<channel>.
DRIVER_CHANNELS = (
    "Thumb_Flexion",
    "Thumb_Opposition",
    "Index_Finger_Distal",
    "Index_Finger_Proximal",
    "Middle_Finger_Distal",
    "Middle_Finger_Proximal",
    "Ring_Finger",
    "Pinky",
    "Finger_Spread",
)
ARM_CONTROLLER = "scaled_pos_joint_traj_controller"
ACTION = "follow_joint_trajectory"
NODE_NAME = "svhdesc_sim"
NODE_SCRIPT = "svhdesc_sim"  # the executable in each variant's scripts/ that roslaunch starts
CONNECTOR_ROOT = "/mujoco"


def hand_controller(prefix: str) -> str:
    return f"{prefix}_controller"


def connector_topics(joint: str) -> dict[str, str]:
    """Topics of the thesis' connector file for ``joint`` (control in, pose out, initpose in)."""
    return {
        "control_topic": f"{CONNECTOR_ROOT}/{joint}/control",
        "pose_topic": f"{CONNECTOR_ROOT}/{joint}/pose",
        "initpose_topic": f"{CONNECTOR_ROOT}/{joint}/initpose",
    }


# JointTrajectoryController's own defaults where a config declares no `constraints`
# (ros_controllers tolerances.h, getSegmentTolerances).
JTC_DEFAULTS = {"goal": 0.0, "trajectory": 0.0, "goal_time": 0.0, "stopped_velocity_tolerance": 0.01}

# Each controller's default `constraints` as its real driver configures them. SCHUNK's
# schunk_svh_driver (cfg/right_hand_controllers.yaml) declares none, so the hand gets the JTC defaults
# above: no position check, only |velocity| <= 0.01 rad/s when the trajectory ends. ur_robot_driver
# (config/ur5_controllers.yaml) sets the arm's. The node uses them unless /<controller>/constraints/...
# are set; ros_controllers.yaml carries the same (no `constraints:` for the hand, as SCHUNK's file).
CONSTRAINTS = {
    "hand": dict(JTC_DEFAULTS),
    "arm": {"goal": 0.1, "trajectory": 0.2, "goal_time": 0.6, "stopped_velocity_tolerance": 0.05},
}
DECLARES_CONSTRAINTS = {"hand": False, "arm": True}
# state_publish_rate / action_monitor_rate: SCHUNK's config leaves the JTC defaults (50 / 20 Hz);
# ur5_controllers.yaml sets 125 (its loop_hz) / 10.
STATE_PUBLISH_RATE = {"hand": 50.0, "arm": 125.0}
# How often each simulated controller updates (checks its tolerances, samples its state): the arm at
# ur_robot_driver's loop_hz 125, the hand on the 100 Hz /clock grid (a multiple of its 50 Hz state).
CONTROLLER_UPDATE_RATE = {"hand": 100.0, "arm": 125.0}
ACTION_MONITOR_RATE = {"hand": 20.0, "arm": 10.0}
# SCHUNK's SVHRosControlHWInterface registers joint velocities but never writes them (always 0), so
# its controller's stopped-velocity check always passes; ur_robot_driver reports measured velocities.
REPORTS_VELOCITY = {"hand": False, "arm": True}

# The controllers each real driver loads (ur5_bringup.launch: `controllers` are started,
# `stopped_controllers` loaded and stopped), as /controller_manager/list_controllers reports them.
# Only the ones the simulation implements are listed: see README (ROS node, deviations).
JOINT_STATE_CONTROLLER = "joint_state_controller"
ARM_STOPPED_CONTROLLER = "pos_joint_traj_controller"
ARM_VELOCITY_CONTROLLER = "joint_group_vel_controller"
CONTROLLER_TYPES = {
    JOINT_STATE_CONTROLLER: "joint_state_controller/JointStateController",
    ARM_CONTROLLER: "position_controllers/ScaledJointTrajectoryController",
    ARM_STOPPED_CONTROLLER: "position_controllers/JointTrajectoryController",
    ARM_VELOCITY_CONTROLLER: "velocity_controllers/JointGroupVelocityController",
    "hand": "position_controllers/JointTrajectoryController",
}

# --- ROS 2 (Jazzy): SCHUNK's schunk_svh_ros_driver (branch ros2, cfg/schunk_svh_driver.yaml, urdf/
# schunk_svh_driver.xacro) and ur_robot_driver ROS 2 (config/ur_controllers.yaml, ur5_update_rate.yaml).
# The hand's controller is named after its side (`right_hand`), the arm's `scaled_joint_trajectory_controller`;
# both run at the controller manager's 125 Hz. ROS 2's SVH joints are `Right_Hand_<X>` where ROS 1's are
# `right_hand_<X>` (the driver's xacro calls the svh macro with name="Right_Hand"); the arm's are unchanged.
ROS2_ARM_CONTROLLER = "scaled_joint_trajectory_controller"
ROS2_JOINT_STATE_BROADCASTER = "joint_state_broadcaster"
ROS2_UPDATE_RATE = 125
ROS2_HAND_PREFIXES = {"right_hand_": "Right_Hand_", "left_hand_": "Left_Hand_"}
# Each controller's constraints: SCHUNK's yaml declares none (JTC's defaults); ur_controllers.yaml sets the arm's.
ROS2_CONSTRAINTS = {
    "hand": dict(JTC_DEFAULTS),
    "arm": {"goal": 0.1, "trajectory": 0.2, "goal_time": 0.0, "stopped_velocity_tolerance": 0.2},
}


def ros2_joint_name(name: str) -> str:
    """A joint's name under SCHUNK's ROS 2 driver: ``right_hand_Pinky`` -> ``Right_Hand_Pinky``; others unchanged."""
    for ros1, ros2 in ROS2_HAND_PREFIXES.items():
        if name.startswith(ros1):
            return ros2 + name[len(ros1) :]
    return name


def ros2_hand_controller(prefix: str) -> str:
    """``right_hand`` (the ROS 1 joints' prefix) -> the ROS 2 driver's controller ``right_hand``."""
    return prefix.lower()


# forward_command_controller's position group, loaded inactive (switch_controller swaps it with the trajectory
# controller): ur_robot_driver ROS 2's ur_controllers.yaml has `forward_position_controller` over the arm's six
# joints; SCHUNK's ROS 2 driver has none, so the hand's takes that name on a hand alone and
# `<hand controller>_forward_position_controller` beside an arm's.
ROS2_FORWARD_CONTROLLER = "forward_position_controller"
ROS2_FORWARD_TYPE = "position_controllers/JointGroupPositionController"
ROS2_JTC_TYPE = "joint_trajectory_controller/JointTrajectoryController"


# A continuous joint's velocity servo (joints.NAME.servo: velocity) gets forward_command_controller's velocity
# group, running (no other controller claims those joints), in ROS 1 and ROS 2 alike, as ros2_control's demos name
# it; the trajectory and position controllers leave those joints out.
VELOCITY_SERVO_CONTROLLER = "forward_velocity_controller"
VELOCITY_SERVO_TYPE = "velocity_controllers/JointGroupVelocityController"


def ros2_hand_forward_controller(hand_controller: str, with_arm: bool) -> str:
    """The hand's forward position controller: ``forward_position_controller``, ``right_hand_forward_...`` on an arm."""
    return f"{hand_controller}_{ROS2_FORWARD_CONTROLLER}" if with_arm else ROS2_FORWARD_CONTROLLER


# --- The batch model (svhdesc.batch, MuJoCo Warp / MJX): what its exporter promises, what validate holds it to ---

BATCH_SCENE_FILE = "scene_batch.xml"
BATCH_OPTIONS = {"solver": "Newton", "cone": "elliptic", "integrator": "implicitfast"}
BATCH_TOLERANCE = 1e-6  # MuJoCo Warp's floor for opt.tolerance (float32)
BATCH_MAX_HULL_VERTICES = 20  # a hull this small cannot have a face above MJX's 20-vertex limit


def batch_model_file(name: str) -> str:
    return f"{name}_batch.xml"


USD_FILE = "{robot}.usda"  # Isaac Sim / Isaac Lab and Newton: one USD layer with the couplings as mimic joints


# --- A built variant: its folder and files ----------------------------------------------------------------------


@dataclass(frozen=True)
class HandId:
    """A built model's hand: its names' prefix (``<prefix>_<part>``; None: parts keep their own names) and its side
    (right, left, or None where the config did not say), as the build resolved them from its config."""

    prefix: str | None
    side: str | None

    def name(self, part: str) -> str:
        """A hand part's name in the model: ``right_hand_e1`` of ``e1``."""
        return f"{self.prefix}_{part}" if self.prefix else part

    def short(self, name: str) -> str:
        """A hand name without the prefix: ``Pinky`` of ``right_hand_Pinky`` (other names as they are)."""
        return name.removeprefix(f"{self.prefix}_") if self.prefix else name

    def owns(self, name: str) -> bool:
        """Whether ``name`` (a joint, a body) is one of the hand's: it carries the prefix (a hand without one owns
        nothing by name)."""
        return bool(self.prefix) and name.startswith(f"{self.prefix}_")


@dataclass(frozen=True)
class Model:
    name: str
    directory: Path

    @property
    def urdf_path(self) -> Path:
        return self.directory / f"{self.name}.urdf"

    @property
    def mjcf_path(self) -> Path:
        return self.directory / f"{self.name}.xml"

    @property
    def scene_path(self) -> Path:
        return self.directory / "scene.xml"

    @property
    def usd_path(self) -> Path:
        """The USD layer (Isaac Sim / Isaac Lab, Newton): articulation, drives, the couplings as mimic joints."""
        return self.directory / USD_FILE.format(robot=self.name)

    @property
    def batch_path(self) -> Path:
        """The batch model for MuJoCo Warp / MJX (svhdesc.batch)."""
        return self.directory / batch_model_file(self.name)

    @property
    def batch_scene_path(self) -> Path:
        return self.directory / BATCH_SCENE_FILE

    @property
    def package_name(self) -> str:
        """The ROS package this folder is (put its parent on ROS_PACKAGE_PATH)."""
        from svhdesc.core.source.packages import package_name_of

        return package_name_of(self.directory) or self.name

    def mesh_file(self, uri: str) -> Path | None:
        """A mesh URI of this model as a local file: package:// of this folder's package or of one on
        ROS_PACKAGE_PATH (model:// alike), file://, absolute and relative paths. None if nothing resolves it."""
        from svhdesc.core.source.packages import local_mesh_path

        return local_mesh_path(uri, self.directory)

    def urdf_text(self, uris: Literal["package", "file", "path"] = "package") -> str:
        """The URDF with mesh URIs as shipped (package://), as file:// URIs, or as plain absolute paths."""
        text = self.urdf_path.read_text()
        if uris == "package":
            return text
        if uris not in ("file", "path"):
            raise ValueError(f"uris must be 'package', 'file' or 'path', not {uris!r}")
        from lxml import etree

        tree = etree.fromstring(text.encode())
        for compiler in tree.iterfind("mujoco/compiler[@meshdir]"):  # MuJoCo's importer, from anywhere too
            compiler.set("meshdir", str((self.directory / compiler.get("meshdir")).resolve()))
        for mesh in tree.iter("mesh"):
            path = self.mesh_file(mesh.get("filename", ""))
            if path is not None:
                absolute = path.resolve()
                mesh.set("filename", absolute.as_uri() if uris == "file" else str(absolute))
        return etree.tostring(tree, xml_declaration=True, encoding="utf-8").decode()

    def absolute_urdf_path(self, uris: Literal["file", "path"] = "path") -> Path:
        """A URDF file whose meshes are absolute (for pybullet, pinocchio, Drake, DART without ROS), cached by
        content under $XDG_CACHE_HOME/svhdesc/urdf; the shipped files stay untouched."""
        text = self.urdf_text(uris)
        digest = hashlib.sha256(text.encode()).hexdigest()[:16]
        cache = user_cache("urdf")
        path = cache / f"{self.name}-{digest}.urdf"
        if not path.is_file():
            cache.mkdir(parents=True, exist_ok=True)
            with tempfile.NamedTemporaryFile("w", dir=cache, delete=False, suffix=".tmp") as handle:
                handle.write(text)
            os.replace(handle.name, path)  # atomic: a reader never sees half a file
        return path

    def manifest(self) -> dict[str, Any] | None:
        """The build's manifest.json (every input, output and tool by hash); None where there is none."""
        from svhdesc.core import manifest

        return manifest.read(self.directory)

    @property
    def hand(self) -> HandId | None:
        """The hand the build wrote into the manifest (None: no manifest, or one from before it held the hand)."""
        entry = (self.manifest() or {}).get("hand")
        if not isinstance(entry, dict):
            return None
        return HandId(entry.get("prefix"), entry.get("side"))

    def configuration(self, config: Path | None = None) -> Configuration | None:
        """What the config that built this model says: the variant of this name in ``config``, else in the
        default config or a config the manifest names (package://svhdesc/config/...). None where none does."""
        from svhdesc.core.settings.config import load_config

        for candidate in [config] if config else [default_config(), *self._manifest_configs()]:
            try:
                variants = load_config(candidate).variants
            except SvhdescError:
                continue
            if self.name in variants:
                variant = variants[self.name]
                return Configuration(variant.name, variant.config_dir, dict(variant.args), variant.settings)
        return None

    def _manifest_configs(self) -> list[Path]:
        inputs = (self.manifest() or {}).get("inputs", {})
        paths = []
        for uri in inputs:
            if uri.startswith("package://svhdesc/config/") and uri.endswith(".yaml"):
                path = source_root() / uri.removeprefix("package://svhdesc/")
                if path.is_file() and path != default_config():
                    paths.append(path)
        return paths


def variants() -> list[str]:
    root = generated_dir()
    return sorted(p.name for p in root.iterdir() if (p / f"{p.name}.xml").is_file()) if root.is_dir() else []


def get(name: str | os.PathLike[str]) -> Model:
    """A shipped variant by name, or any built variant by its folder (``<folder>/<folder name>.xml``)."""
    folder = Path(name)
    if folder.is_dir() and (folder / f"{folder.name}.xml").is_file():
        return Model(folder.name, folder.resolve())
    name = str(name)
    if name not in variants():
        raise KeyError(f"unknown variant {name!r}; available: {', '.join(variants())}")
    return Model(name, generated_dir() / name)


@dataclass(frozen=True)
class Configuration:
    """The runtime's read-only view of the config variant that built a model."""

    variant: str
    config_dir: Path
    args: Mapping[str, str]  # the xacro arguments
    settings: Any  # the typed sections (svhdesc.core.settings.schema.Settings): .hand, .mass, .grasps, ...

    def channels(self) -> dict[str, Channel]:
        """The coupling spec's channels (the real driver's motors), by unprefixed name."""
        from svhdesc.core.settings.coupling import load_spec

        if self.settings.coupling is None:
            return {}  # configured without a coupling spec: no channels
        spec = load_spec(Path(self.config_dir) / str(self.settings.coupling))
        return {c.name: c for c in spec.channels}


# --- What a compiled model holds: joints, actuators, couplings ----------------------------------------------------


@dataclass(frozen=True)
class Coupling:
    """A coupled joint follows its leader (a driver channel): q_joint = sum(coeffs[k] * q_leader**k).

    Read from a MuJoCo joint equality (``name``: the equality's; five coefficients, about qpos0 = 0 as every built
    model has it) or from a URDF ``<mimic>`` (two: offset, multiplier)."""

    joint: str
    leader: str
    coeffs: tuple[float, ...]  # constant term first
    name: str = ""

    def value(self, q: np.ndarray | float) -> np.ndarray | float:
        return polyval(self.coeffs, q)

    @property
    def linear(self) -> bool:
        return not any(self.coeffs[2:])

    @property
    def offset(self) -> float:
        """The constant term of a linear coupling (a URDF <mimic>'s offset)."""
        self._require_linear()
        return self.coeffs[0] if self.coeffs else 0.0

    @property
    def multiplier(self) -> float:
        """The slope of a linear coupling (a URDF <mimic>'s multiplier)."""
        self._require_linear()
        return self.coeffs[1] if len(self.coeffs) > 1 else 0.0

    def _require_linear(self) -> None:
        if not self.linear:
            raise ValueError(f"coupling of {self.joint} is a polynomial of order > 1: no offset/multiplier")


def scalar_joints(model: Any) -> list[int]:
    """Hinge and slide joints of a MuJoCo model: one qpos each, what a URDF revolute/prismatic joint becomes."""
    import mujoco

    kinds = {int(mujoco.mjtJoint.mjJNT_HINGE), int(mujoco.mjtJoint.mjJNT_SLIDE)}
    return [j for j in range(model.njnt) if int(model.jnt_type[j]) in kinds]


def random_target_start(model: Any) -> tuple[Any, np.ndarray, np.ndarray]:
    """Data at the ``home`` keyframe (qpos0 without one), and each actuator's range for random targets: its
    ctrlrange, +-1 for a servo without limits (a continuous joint's). What validate's simulate check and the build's
    trial run both drive a model with."""
    import mujoco

    data = mujoco.MjData(model)
    home = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_KEY, "home")
    if home >= 0:
        mujoco.mj_resetDataKeyframe(model, data, home)
    low, high = model.actuator_ctrlrange.T.copy()
    unlimited = model.actuator_ctrllimited == 0
    low[unlimited], high[unlimited] = -1.0, 1.0
    return data, low, high


# The random-target run: validate's simulate check, and the build's trial run, which refuses a model it finds
# diverging, so that validate's default run (seed 0) never finds a divergence in a model the build passed.
RANDOM_TARGET_SECONDS = 10.0  # s of simulated time
RANDOM_TARGET_PERIOD = 0.05  # s between new random targets (the full ctrlrange: a hard test of the couplings)
RANDOM_TARGET_SEED = 0  # validate's default --seed: the build runs the same draws
DIVERGENCE_ADVICE = (  # what helps a model MuJoCo cannot integrate (icub's light arms against elliptic-cone contacts)
    "simulation.cone: pyramidal where contacts are involved, a smaller simulation.timestep, a lower kp (arm.kp, "
    "hand.kp) or joints.NAME.effort on that joint"
)


@dataclass(frozen=True)
class Divergence:
    """Where MuJoCo first found the state bad (a bad acceleration, velocity or position, or a non-finite state):
    the time before that step, the joint, and the contacts then active."""

    time: float
    joint: str
    contacts: int

    def __str__(self) -> str:
        where = f"at t = {self.time:.3f} s at joint {self.joint} ({self.contacts} contacts)"
        return f"diverged {where}: {DIVERGENCE_ADVICE}"


@dataclass
class RandomTargetRun:
    """What a random-target run found: MuJoCo's warnings (name -> count), when the state turned non-finite, and the
    first divergence."""

    warnings: dict[str, int]
    nan_at: float | None = None
    diverged: Divergence | None = None


def run_random_targets(model: Any, seed: int, each_step: Any = None, until_diverged: bool = False) -> RandomTargetRun:
    """RANDOM_TARGET_SECONDS s from ``home``: a new target drawn uniformly across each actuator's range (seeded)
    every RANDOM_TARGET_PERIOD s. ``each_step(data)`` runs after every step; the run ends at a non-finite state, or
    at the first divergence when ``until_diverged``. (MuJoCo resets the state when it warns, so the time, the
    speeds and the contacts are read before each step.)"""
    import mujoco

    data, low, high = random_target_start(model)
    rng, period = np.random.default_rng(seed), max(1, round(RANDOM_TARGET_PERIOD / model.opt.timestep))
    run = RandomTargetRun({})
    for step in range(round(RANDOM_TARGET_SECONDS / model.opt.timestep)):
        if step % period == 0:
            data.ctrl[:] = rng.uniform(low, high)
        before = (float(data.time), np.abs(data.qvel), int(data.ncon))
        mujoco.mj_step(model, data)
        finite = all(np.isfinite(v).all() for v in (data.qpos, data.qvel, data.qacc))
        if run.diverged is None:
            run.diverged = _divergence(model, data, finite, before)
        if not finite:
            run.nan_at = step * model.opt.timestep
        if run.nan_at is not None or (until_diverged and run.diverged is not None):
            break
        if each_step is not None:
            each_step(data)
    run.warnings = warning_counts(data)
    return run


def _divergence(model: Any, data: Any, finite: bool, before: tuple[float, np.ndarray, int]) -> Divergence | None:
    """The divergence this step found, if any: the joint MuJoCo names (a bad acceleration or velocity), else the
    fastest one before the step."""
    import mujoco

    warned = [data.warning[int(w)] for w in (mujoco.mjtWarning.mjWARN_BADQACC, mujoco.mjtWarning.mjWARN_BADQVEL)]
    if finite and not data.warning[int(mujoco.mjtWarning.mjWARN_BADQPOS)].number and not any(w.number for w in warned):
        return None
    when, speeds, contacts = before
    dofs = [int(w.lastinfo) for w in warned if w.number and 0 <= w.lastinfo < model.nv]
    dof = dofs[0] if dofs else int(np.argmax(speeds)) if model.nv else -1
    return Divergence(when, model.joint(int(model.dof_jntid[dof])).name if dof >= 0 else "?", contacts)


def warning_counts(data: Any) -> dict[str, int]:
    """MuJoCo's warnings so far: name -> count, those that occurred."""
    import mujoco

    members = mujoco.mjtWarning.__members__.items()
    counts = {name: int(data.warning[int(v)].number) for name, v in members if int(v) < len(data.warning)}
    return {name: n for name, n in counts.items() if n}


def velocity_servos(model: Any) -> set[str]:
    """The joints driven by a velocity servo (force = kv (ctrl - qvel): a bias on the velocity, none on the
    position), not a position servo."""
    import mujoco

    joint = int(mujoco.mjtTrn.mjTRN_JOINT)
    return {
        model.joint(int(model.actuator_trnid[a, 0])).name
        for a in range(model.nu)
        if int(model.actuator_trntype[a]) == joint
        and model.actuator_biasprm[a, 1] == 0
        and model.actuator_biasprm[a, 2] < 0
    }


def actuated_joints(model: Any) -> dict[str, tuple[float, float]]:
    """Joint name -> commanded range of the actuator driving it (joint range if not ctrllimited); a velocity
    servo's joint: its own range (any angle for a continuous joint), not the velocities commanded."""
    import mujoco

    # Compare as ints: numpy scalars and MuJoCo's enums do not meet in a tuple's `in`.
    joint_kinds = {int(mujoco.mjtTrn.mjTRN_JOINT), int(mujoco.mjtTrn.mjTRN_JOINTINPARENT)}
    result = {}
    velocity = velocity_servos(model)
    for i in range(model.nu):
        if int(model.actuator_trntype[i]) not in joint_kinds:
            continue
        joint = int(model.actuator_trnid[i, 0])
        if model.actuator_ctrllimited[i] and model.joint(joint).name not in velocity:
            low, high = model.actuator_ctrlrange[i]
        elif model.jnt_limited[joint]:
            low, high = model.jnt_range[joint]
        else:  # a continuous joint's servo: any angle
            low, high = -math.inf, math.inf
        result[model.joint(joint).name] = (float(low), float(high))
    return result


def couplings(model: Any) -> list[Coupling]:
    """A MuJoCo model's joint equalities between two joints (the coupled joint first), in model order."""
    import mujoco

    result = []
    for i in range(model.neq):
        if int(model.eq_type[i]) != int(mujoco.mjtEq.mjEQ_JOINT) or model.eq_obj2id[i] < 0:
            continue
        result.append(
            Coupling(
                model.joint(int(model.eq_obj1id[i])).name,
                model.joint(int(model.eq_obj2id[i])).name,
                tuple(float(c) for c in model.eq_data[i, :5]),
                model.eq(i).name,
            )
        )
    return result


def mimic_coupling(joint: etree._Element) -> Coupling | None:
    """A URDF ``<joint>``'s ``<mimic>`` as a Coupling (offset, multiplier); None for a joint without one."""
    mimic = joint.find("mimic")
    if mimic is None:
        return None
    coeffs = (float(mimic.get("offset", "0")), float(mimic.get("multiplier", "1")))
    return Coupling(joint.get("name"), mimic.get("joint"), coeffs)


def urdf_couplings(urdf: Path) -> list[Coupling]:
    """A URDF's ``<mimic>`` joints, in the URDF's order."""
    from lxml import etree

    root = etree.parse(str(urdf)).getroot()
    return [coupling for joint in root.iter("joint") if (coupling := mimic_coupling(joint)) is not None]


def urdf_velocity_limits(urdf: Path) -> dict[str, float]:
    """Joint name -> the URDF's ``<limit velocity>`` [rad/s], for every joint that declares one."""
    from lxml import etree

    root = etree.parse(str(urdf)).getroot()
    limits = {}
    for joint in root.iter("joint"):
        limit = joint.find("limit")
        if limit is not None and limit.get("velocity") is not None:
            limits[joint.get("name")] = float(limit.get("velocity"))
    return limits


# --- The vendor sources as the compiler reads them (checks against the vendor's own geometry) --------------------


def expand_source(xacro: Path, args: Mapping[str, str], packages: Mapping[str, Path]) -> etree._Element:
    """A Xacro entry point expanded as the build expands it (no ROS installation needed)."""
    from svhdesc.core.source.xacro import expand_xacro

    return expand_xacro(xacro, args, packages)[0]


def load_source_mesh(path: Path, scale: tuple[float, float, float] = (1.0, 1.0, 1.0)) -> trimesh.Trimesh:
    """A .dae/.stl/.obj as the build reads it: one welded mesh in metres, COLLADA frame and ``scale`` applied."""
    from svhdesc.core.source.meshes import load_mesh

    return load_mesh(path, scale)
