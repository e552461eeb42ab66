"""A variant's scene in MuJoCo, driven by joint targets and trajectories; no ROS needed.

Hand channels move as the SVH's firmware moves them: its position controller ramps the setpoint toward the
command at most at the channel's velocity limit (the driver's maximum step per second, the URDF's ``<limit
velocity>``), so a step command takes its time as on the robot. The MJCF alone has no such limit.

sim = Simulation("ur5_svh_right", keyframe="home")
sim.follow(["shoulder_pan_joint"], [Point(2.0, (1.0,))])
sim.advance(2.5)
sim.joint_state()             # every joint, coupled ones included
"""

from __future__ import annotations

import math
import time as wallclock
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from svhdesc.control.spline import Point, State, Trajectory, validate_points
from svhdesc.errors import SvhdescError
from svhdesc.model import urdf_velocity_limits
from svhdesc.sim.robot import RobotInfo, describe

# s: how often ``step``/``advance`` update the controllers (``run`` updates them at its callbacks too)
CONTROL_PERIOD = 0.002


def _grid(every: float | Sequence[float], timestep: float) -> list[int]:
    """The callback periods in whole physics steps (at least one)."""
    periods = [every] if isinstance(every, (int, float)) else list(every)
    if not periods or not all(math.isfinite(p) and p > 0 for p in periods):
        raise SvhdescError(f"callback periods must be positive: {every}")
    return sorted({max(1, round(p / timestep)) for p in periods})


@dataclass(frozen=True)
class JointState:
    names: tuple[str, ...]
    positions: np.ndarray
    velocities: np.ndarray
    efforts: np.ndarray


@dataclass
class _Active:
    """A trajectory and the actuators it still drives (a later goal may take some over)."""

    trajectory: Trajectory
    columns: list[int]
    actuators: list[int]


def _compensate_gravity(spec: Any) -> None:
    """The real drivers hold their pose against gravity (the UR's controller, the SVH's position
    loop); a bare position servo would sag. Models that already carry gravcomp keep theirs."""
    bodies = list(spec.bodies)[1:]
    if any(body.gravcomp for body in bodies):
        return
    for body in bodies:
        body.gravcomp = 1.0
    actuated = {actuator.target for actuator in spec.actuators}
    for joint in spec.joints:
        if joint.name in actuated:
            joint.actgravcomp = True


class Simulation:
    def __init__(
        self,
        variant: str,
        keyframe: str | None = "home",
        gravity_compensation: bool = True,
        edit: Callable[[Any], None] | None = None,
        setpoint_ramp: bool = True,
    ) -> None:
        """``edit`` may change the scene's ``mujoco.MjSpec`` before it compiles (add objects); ``setpoint_ramp``
        False lets the hand's servos take a command at once (faster than the real hand)."""
        import mujoco

        from svhdesc.model import get

        self._mj = mujoco
        try:
            built = get(variant)
        except KeyError as exc:
            raise SvhdescError(str(exc.args[0])) from None
        scene = built.scene_path
        self.variant = variant
        spec = mujoco.MjSpec.from_file(str(scene))
        if gravity_compensation:
            _compensate_gravity(spec)
        if edit is not None:
            edit(spec)
        self.model = spec.compile()
        self.data = mujoco.MjData(self.model)
        self._timestep = float(self.model.opt.timestep)  # read at every control update: kept, not re-read
        self.info: RobotInfo = describe(self.model, built.hand)
        self._act_index = {name: i for i, name in enumerate(self.info.actuators)}
        self._qpos = np.array([self.model.joint(j).qposadr[0] for j in self.info.joints], dtype=int)
        self._qvel = np.array([self.model.joint(j).dofadr[0] for j in self.info.joints], dtype=int)
        self._act_qpos = np.array([self.model.joint(a).qposadr[0] for a in self.info.actuators], dtype=int)
        self._act_qvel = np.array([self.model.joint(a).dofadr[0] for a in self.info.actuators], dtype=int)
        self._ctrlrange = self.model.actuator_ctrlrange.copy()
        self._ctrlrange[self.model.actuator_ctrllimited == 0] = (-math.inf, math.inf)  # a continuous joint's servo
        # velocity servos: their target is a velocity (held: 0), never a position or a trajectory
        self._velocity = np.array([a in self.info.velocity_joints for a in self.info.actuators], dtype=bool)
        # joint_state's efforts: the actuator force of each actuated joint, 0 on the coupled ones
        effort_of = {name: a for a, name in enumerate(self.info.actuators)}
        self._effort_cols = np.array([k for k, j in enumerate(self.info.joints) if j in effort_of], dtype=int)
        self._effort_acts = np.array([effort_of[j] for j in self.info.joints if j in effort_of], dtype=int)
        self._bodies: dict[str, int] = {}
        self._index_cache: dict[tuple[str, ...], list[int]] = {}
        self._addresses: dict[tuple[str, ...], tuple[np.ndarray, np.ndarray]] = {}  # joints -> (qpos, qvel)
        self._identity = list(range(len(self.info.actuators)))
        limits = urdf_velocity_limits(built.urdf_path) if setpoint_ramp else {}
        ramped = [(self._act_index[j], limits[j]) for j in self.info.hand_channels if limits.get(j, 0.0) > 0.0]
        self._ramped = np.array([i for i, _ in ramped], dtype=int)
        self._ramp_step = np.array([v * self.timestep for _, v in ramped])  # rad per physics step
        self._setpoint = np.zeros(len(ramped))  # what the firmware's ramp has reached
        self._active: list[_Active] = []
        self._step_hooks: list[Callable[[], None]] = []
        self.control_steps = max(1, round(CONTROL_PERIOD / self.timestep))  # physics steps per controller update
        warn = mujoco.mjtWarning
        self._bad_kinds = [int(warn.mjWARN_BADQPOS), int(warn.mjWARN_BADQVEL), int(warn.mjWARN_BADQACC)]
        self._warning_counts = self.data.warning.number  # a view into mjData, read after every chunk
        self.reset(keyframe)

    # -- setup -------------------------------------------------------------------------------
    def reset(self, keyframe: str | None = "home") -> None:
        """Back to ``keyframe`` (or the model's zero pose): state, targets and trajectories."""
        mujoco = self._mj
        if keyframe is None:
            mujoco.mj_resetData(self.model, self.data)
        else:
            if keyframe not in self.info.keyframes:
                raise SvhdescError(
                    f"{self.variant} has no keyframe {keyframe!r}; it has: {', '.join(self.info.keyframes) or 'none'}"
                )
            mujoco.mj_resetDataKeyframe(self.model, self.data, self.model.key(keyframe).id)
            self.data.ctrl[:] = np.where(self._velocity, 0.0, self.data.qpos[self._act_qpos])
        self._active.clear()
        self._setpoint = self.data.ctrl[self._ramped].astype(float)
        mujoco.mj_forward(self.model, self.data)

    # -- names -------------------------------------------------------------------------------
    def actuator(self, name: str) -> int:
        """Index of the actuator driving ``name``: a joint name or a bare channel name."""
        if name in self._act_index:
            return self._act_index[name]
        prefixed = f"{self.info.hand_prefix}_{name}"
        if self.info.hand_prefix and prefixed in self._act_index:
            return self._act_index[prefixed]
        raise SvhdescError(f"{name!r} is not an actuated joint of {self.variant}")

    def _indices(self, names: Sequence[str]) -> list[int]:
        """The actuators of ``names`` (remembered: controllers ask for the same names at every update)."""
        key = tuple(names)
        indices = self._index_cache.get(key)
        if indices is None:
            indices = self._index_cache[key] = [self.actuator(n) for n in names]
        return list(indices)

    def limits(self, name: str) -> tuple[float, float]:
        """The commandable range of actuated joint ``name`` (its servo's ctrlrange)."""
        low, high = self._ctrlrange[self.actuator(name)]
        return float(low), float(high)

    @property
    def time(self) -> float:
        return float(self.data.time)

    @property
    def timestep(self) -> float:
        return self._timestep

    # -- commands ----------------------------------------------------------------------------
    def set_target(self, name: str, value: float) -> None:
        """Servo ``name`` to ``value`` (clamped to its range); stops any trajectory on it."""
        if not math.isfinite(value):
            raise SvhdescError(f"target for {name!r} is not finite: {value}")
        index = self.actuator(name)
        self._release([index])
        low, high = self._ctrlrange[index]
        self.data.ctrl[index] = min(max(value, low), high)

    def set_targets(self, targets: Mapping[str, float]) -> None:
        for name, value in targets.items():
            self.set_target(name, value)

    def targets(self) -> dict[str, float]:
        return {name: float(self.data.ctrl[i]) for name, i in self._act_index.items()}

    def set_gains(self, name: str, p_gain: float, d_gain: float) -> None:
        """ctrl force = -p_gain (q - q_ref) - d_gain q_dot (thesis eq. 4.2) on ``name``'s servo."""
        if not (math.isfinite(p_gain) and math.isfinite(d_gain)) or p_gain < 0 or d_gain < 0:
            raise SvhdescError(f"gains for {name!r} must be finite and non-negative: p {p_gain}, d {d_gain}")
        index = self._position_servo(name)
        self.model.actuator_gainprm[index, 0] = p_gain
        self.model.actuator_biasprm[index, 1] = -p_gain
        self.model.actuator_biasprm[index, 2] = -d_gain

    def _position_servo(self, name: str) -> int:
        """The actuator of ``name``, which must be a position servo (a velocity servo takes velocities only)."""
        index = self.actuator(name)
        if self._velocity[index]:
            raise SvhdescError(f"{name!r} is on a velocity servo: command its velocity (set_target), not a position")
        return index

    def gains(self, name: str) -> tuple[float, float]:
        index = self.actuator(name)
        return float(self.model.actuator_gainprm[index, 0]), float(-self.model.actuator_biasprm[index, 2])

    def set_joint_position(self, name: str, value: float) -> None:
        """Teleport an actuated joint (and the joints coupled to it) to ``value``, at rest, held there."""
        if not math.isfinite(value):
            raise SvhdescError(f"position for {name!r} is not finite: {value}")
        index = self.actuator(name)
        joint = self.info.actuators[index]
        low, high = self._ctrlrange[index] if not self._velocity[index] else self.model.joint(joint).range
        if self._velocity[index] and not self.model.jnt_limited[self.model.joint(joint).id]:
            low, high = -math.inf, math.inf
        value = min(max(value, low), high)
        self._release([index])
        self.data.ctrl[index] = 0.0 if self._velocity[index] else value
        self._setpoint[self._ramped == index] = value
        self.data.qpos[self._act_qpos[index]] = value
        self.data.qvel[self._act_qvel[index]] = 0.0
        for coupling in self.info.couplings:
            if coupling.leader == joint:
                j = self.model.joint(coupling.joint)
                self.data.qpos[j.qposadr[0]] = coupling.value(value)
                self.data.qvel[j.dofadr[0]] = 0.0
        self._mj.mj_forward(self.model, self.data)

    def desired(self, names: Sequence[str], at: float | None = None) -> State:
        """The commanded state of actuated joints ``names`` now (trajectory sample or held target)."""
        at = self.time if at is None else at
        indices = self._indices(names)
        for active in self._active:
            if active.actuators == indices:  # one trajectory drives exactly these (an actuator has one at most)
                state = active.trajectory.sample(at)
                if active.columns == self._identity[: len(indices)]:
                    return state
                columns = active.columns
                return State(state.positions[columns], state.velocities[columns], state.accelerations[columns])
        positions = self.data.ctrl[indices].astype(float)
        velocities = np.zeros(len(indices))
        accelerations = np.zeros(len(indices))
        where = {a: k for k, a in enumerate(indices)}
        for active in self._active:
            state = None
            for column, actuator in zip(active.columns, active.actuators):
                if actuator in where:
                    state = state or active.trajectory.sample(at)
                    k = where[actuator]
                    positions[k] = state.positions[column]
                    velocities[k] = state.velocities[column]
                    accelerations[k] = state.accelerations[column]
        return State(positions, velocities, accelerations)

    def follow(self, names: Sequence[str], points: Sequence[Point], start_time: float | None = None) -> Trajectory:
        """Follow ``points`` on the actuated joints ``names`` from ``start_time`` (default: now).

        Joints not named keep what they were doing. Positions outside a joint's range are refused
        (the servo would clamp them and the trajectory could never be reached)."""
        indices = [self._position_servo(n) for n in names]
        if len(set(indices)) != len(indices):
            raise SvhdescError(f"joint names repeat: {list(names)}")
        problem = validate_points(points, len(indices))
        if problem:
            raise SvhdescError(problem)
        for point in points:
            for value, index in zip(point.positions, indices):
                low, high = self._ctrlrange[index]
                if not low - 1e-9 <= value <= high + 1e-9:
                    raise SvhdescError(
                        f"{self.info.actuators[index]}: position {value} is outside its range [{low}, {high}]"
                    )
        now = self.time
        start = self.desired(names, now)
        trajectory = Trajectory(
            [self.info.actuators[i] for i in indices], start, now if start_time is None else start_time, points, now
        )
        self._release(indices)
        self._active.append(_Active(trajectory, list(range(len(indices))), indices))
        return trajectory

    def hold(self, names: Sequence[str]) -> None:
        """Stop trajectories on ``names`` and hold their current positions (a cancel); a velocity servo stops."""
        indices = [self.actuator(n) for n in names]
        self._release(indices)
        self.data.ctrl[indices] = np.where(self._velocity[indices], 0.0, self.data.qpos[self._act_qpos[indices]])
        held = np.isin(self._ramped, indices)
        self._setpoint[held] = self.data.ctrl[self._ramped[held]]

    def _release(self, indices: Sequence[int]) -> None:
        taken = set(indices)
        for active in self._active:
            if taken & set(active.actuators):
                # Freeze the released joints at their current desired position first.
                state = active.trajectory.sample(self.time)
                keep = [(c, a) for c, a in zip(active.columns, active.actuators) if a not in taken]
                for c, a in zip(active.columns, active.actuators):
                    if a in taken:
                        self.data.ctrl[a] = state.positions[c]
                active.columns = [c for c, _ in keep]
                active.actuators = [a for _, a in keep]
        self._active = [a for a in self._active if a.actuators]

    # -- stepping ----------------------------------------------------------------------------
    def add_step_hook(self, hook: Callable[[], None]) -> None:
        """Called after every physics step (for monitors that must see each step); while one is set,
        stepping goes one physics step at a time."""
        self._step_hooks.append(hook)

    def step(self, count: int = 1) -> None:
        """``count`` physics steps; the controller updates every ``control_period`` (see ``_update``)."""
        chunk = 1 if self._step_hooks else self.control_steps
        while count > 0:
            self._chunk(min(chunk, count))
            count -= chunk
        self._check_diverged()

    def _chunk(self, steps: int) -> None:
        """One controller update, then ``steps`` physics steps with no Python between them: the servos are
        MJCF actuators holding the targets (as the drivers' controllers hold theirs between updates)."""
        commanded = self._update(steps)
        self._mj.mj_step(self.model, self.data, steps)
        self.data.ctrl[self._ramped] = commanded
        for hook in self._step_hooks:
            hook()

    def _update(self, steps: int) -> np.ndarray:
        """The controller update for the next ``steps`` physics steps: each trajectory sampled at the first
        step's time becomes its servos' target; the hand's firmware ramp moves its setpoint toward the command
        by at most ``steps`` steps' worth of its velocity limit. Returns the hand's commands (the servos see
        the ramp, the rest of the API the command)."""
        now = self.time + self.timestep
        finished = []
        for active in self._active:
            state = active.trajectory.sample(now)
            self.data.ctrl[active.actuators] = state.positions[active.columns]
            if now >= active.trajectory.end_time:
                finished.append(active)
        for active in finished:
            self._active.remove(active)
        commanded = self.data.ctrl[self._ramped]
        if (commanded != self._setpoint).any():  # else the setpoint has reached the command
            reach = self._ramp_step * steps
            self._setpoint = np.minimum(np.maximum(commanded, self._setpoint - reach), self._setpoint + reach)
            self.data.ctrl[self._ramped] = self._setpoint
        return commanded

    def _check_diverged(self) -> None:
        """Stop at once, naming the joint, when MuJoCo found a bad state (it then resets it to a finite one, so the
        state alone can look fine) or the state went non-finite."""
        counts, (qpos_kind, qvel_kind, qacc_kind) = self._warning_counts, self._bad_kinds
        qpos, qvel = self.data.qpos, self.data.qvel
        if not (counts[qpos_kind] or counts[qvel_kind] or counts[qacc_kind]) and math.isfinite(
            qpos @ qpos + qvel @ qvel
        ):
            return  # the common case, cheaply (a NaN or infinity makes the sums of squares non-finite): every chunk
        mj, warning = self._mj, self.data.warning
        kinds = (mj.mjtWarning.mjWARN_BADQPOS, mj.mjtWarning.mjWARN_BADQVEL, mj.mjtWarning.mjWARN_BADQACC)
        bad = [kind for kind in kinds if warning[kind].number]
        if not bad and np.isfinite(self.data.qpos).all() and np.isfinite(self.data.qvel).all():
            return
        index = int(warning[bad[0]].lastinfo) if bad else int(np.argmin(np.isfinite(self.data.qvel)))
        if bad and bad[0] == mj.mjtWarning.mjWARN_BADQPOS:  # a qpos address: the joint whose coordinates hold it
            joint = int(np.searchsorted(self.model.jnt_qposadr, index, side="right") - 1)
        else:
            joint = int(self.model.dof_jntid[min(index, self.model.nv - 1)])
        name = mj.mj_id2name(self.model, mj.mjtObj.mjOBJ_JOINT, joint)
        raise SvhdescError(f"{self.variant}: the simulation diverged at t = {self.time:.3f} s (joint {name})")

    def advance(self, seconds: float) -> None:
        self.step(max(0, round(seconds / self.timestep)))

    def run(
        self,
        duration: float,
        realtime: bool = True,
        every: float | Sequence[float] = 0.02,
        callback: Callable[[Simulation], bool | None] | None = None,
    ) -> float:
        """Step for ``duration`` simulated seconds (math.inf: until ``callback`` returns False).

        ``callback`` runs at every multiple of each period in ``every`` (simulated seconds since t = 0, so
        rates are exact however the run began); between two such instants the physics runs in one chunk
        (one controller update, then MuJoCo's own loop). Returns the real-time factor."""
        grid = _grid(every, self.timestep)
        begin_wall, begin_sim = wallclock.perf_counter(), self.time
        end = math.inf if not math.isfinite(duration) else round((begin_sim + duration) / self.timestep)
        while True:
            index = round(self.time / self.timestep)
            if index >= end:
                break
            following = min(min((index // p + 1) * p for p in grid), end)
            self.step(int(following - index))
            if callback is not None and callback(self) is False:
                break
            if realtime:
                ahead = (self.time - begin_sim) - (wallclock.perf_counter() - begin_wall)
                if ahead > 0:
                    wallclock.sleep(ahead)
        elapsed = wallclock.perf_counter() - begin_wall
        return (self.time - begin_sim) / elapsed if elapsed > 0 else math.inf

    # -- readings ----------------------------------------------------------------------------
    def joint_state(self) -> JointState:
        """Every joint, coupled ones included; efforts are the actuator forces (0 on coupled joints)."""
        efforts = np.zeros(len(self.info.joints))
        efforts[self._effort_cols] = self.data.actuator_force[self._effort_acts]
        return JointState(
            self.info.joints, self.data.qpos[self._qpos].copy(), self.data.qvel[self._qvel].copy(), efforts
        )

    def positions(self) -> dict[str, float]:
        state = self.joint_state()
        return dict(zip(state.names, state.positions.tolist()))

    def joint_values(self, names: Sequence[str]) -> tuple[np.ndarray, np.ndarray]:
        """Positions and velocities of the joints ``names``, in that order (copies)."""
        key = tuple(names)
        found = self._addresses.get(key)
        if found is None:  # looked up once: controllers sample the same joints at every update
            qpos = np.array([self.model.joint(j).qposadr[0] for j in names], dtype=int)
            found = self._addresses[key] = (qpos, np.array([self.model.joint(j).dofadr[0] for j in names], dtype=int))
        return self.data.qpos[found[0]], self.data.qvel[found[1]]  # indexing by an array copies

    def _body(self, name: str) -> int:
        body = self._bodies.get(name)
        if body is None:  # looked up once: publishers read tracked bodies at every state update
            body = self._mj.mj_name2id(self.model, self._mj.mjtObj.mjOBJ_BODY, name)
            if body < 0:
                raise SvhdescError(f"{self.variant} has no body {name!r}")
            self._bodies[name] = body
        return body

    def body_pose(self, name: str) -> tuple[np.ndarray, np.ndarray]:
        """World position and orientation quaternion (w, x, y, z) of body ``name``."""
        body = self._body(name)
        return self.data.xpos[body].copy(), self.data.xquat[body].copy()

    def fingertip_force(self) -> float:
        """Normal force (N) on the index fingertip's touch sensor; 0 without one."""
        mujoco = self._mj
        for s in range(self.model.nsensor):
            if int(self.model.sensor_type[s]) == int(mujoco.mjtSensor.mjSENS_TOUCH):
                return float(self.data.sensordata[self.model.sensor_adr[s]])
        return 0.0

    def touch_body(self) -> str | None:
        """The body carrying the touch sensor's site (the index fingertip)."""
        mujoco = self._mj
        for s in range(self.model.nsensor):
            if int(self.model.sensor_type[s]) == int(mujoco.mjtSensor.mjSENS_TOUCH):
                site = self.model.sensor_objid[s]
                return self.model.body(self.model.site_bodyid[site]).name
        return None

    def contact_wrench(self, name: str) -> tuple[np.ndarray, np.ndarray]:
        """Total contact force and torque on body ``name`` (about its origin, in its frame), as
        Gazebo's F3D plugin reports them."""
        mujoco = self._mj
        body = self._body(name)
        force, torque = np.zeros(3), np.zeros(3)
        local = np.zeros(6)
        origin = self.data.xpos[body]
        for i in range(self.data.ncon):
            contact = self.data.contact[i]
            bodies = self.model.geom_bodyid[contact.geom1], self.model.geom_bodyid[contact.geom2]
            if body not in bodies or bodies[0] == bodies[1]:
                continue
            mujoco.mj_contactForce(self.model, self.data, i, local)
            frame = contact.frame.reshape(3, 3)
            # The contact frame's normal points from geom1 to geom2; the force acts on geom2.
            sign = 1.0 if bodies[1] == body else -1.0
            f_world = sign * frame.T @ local[:3]
            t_world = sign * frame.T @ local[3:]
            force += f_world
            torque += t_world + np.cross(contact.pos - origin, f_world)
        rotation = self.data.xmat[body].reshape(3, 3)
        return rotation.T @ force, rotation.T @ torque
