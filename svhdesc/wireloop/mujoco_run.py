"""The learned plan executed by the UR5 + SVH in MuJoCo: the 3-D step the paper's conclusion calls for.

The generated ``ur5_svh_right`` scene (or another arm with an SVH: ``SceneConfig.variant``) is loaded through the
public API and extended with ``mujoco.MjSpec``:

- the wire: one capsule per straight run of the map's path, in a horizontal plane below the hand;
- the loop: a ring of capsules in a vertical plane, on a rod below the palm (body ``<prefix>_e1``, the prefix the
  built model names), with a
  site at its centre. The ring's horizontal diameter is the 2-D loop's segment; turning the loop is a yaw
  of the hand about the vertical through the ring's centre.

Each planned grid move becomes an end-effector target (ring centre position and yaw), interpolated over
``move_s``; damped-least-squares inverse kinematics with ``mj_jacSite`` on the 6 arm joints gives the joint
targets, and the model's position servos follow (the hand's channels hold the ``home`` keyframe). The
bodies get gravity compensation (``gravcomp``), as the UR5's own controller gives it.

Ring and wire geoms collide only with each other and the hand (contype/conaffinity bit 2); every control
tick also measures the smallest ring-wire distance (``mj_geomDistance``) to report the clearance.
Rendering runs in a child process (``python -m svhdesc.wireloop.mujoco_run``), since MuJoCo binds its
OpenGL backend at import.
"""

from __future__ import annotations

import json
import math
import sys
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from svhdesc.errors import SvhdescError
from svhdesc.offscreen import draw_png, run_child, stage
from svhdesc.wireloop.env import CCW, CW, Environment
from svhdesc.wireloop.wiremap import WireMap, load_map

VARIANT = "ur5_svh_right"
PALM = "e1"  # the hand's palm link, under the built model's prefix
SITE = "wireloop_centre"
WIRE_BITS = 2  # contype/conaffinity bit shared by wire and ring only


@dataclass(frozen=True)
class SceneConfig:
    pixel: float = 0.01  # m per map pixel
    ring_radius: float = 0.0175  # m; between the grid's diagonal (1.41 px) and axial (2 px) limit distance
    wire_radius: float = 0.0015
    tube_radius: float = 0.0015
    drop: float = 0.32  # m from the palm body down to the ring centre (below the fingertips)
    move_s: float = 0.25  # time per planned action
    control_dt: float = 0.005  # IK and servo targets updated at 200 Hz
    settle_s: float = 0.3
    near: float = 0.05  # ring-wire distances are measured (mj_geomDistance) up to this far
    variant: str = VARIANT  # a shipped variant or a built variant's folder: an arm with an SVH


@dataclass
class MujocoRun:
    actions: int
    sim_s: float
    touched_wire: bool  # a ring geom and a wire geom penetrated
    other_wire_contacts: int  # steps where something other than the ring touched the wire (the hand)
    min_clearance_m: float  # smallest ring-wire surface distance seen (capped at SceneConfig.near)
    worst_position_error_m: float  # ring centre vs its moving target
    worst_yaw_error_deg: float
    worst_waypoint_error_m: float  # at the end of each move
    wall_s: float
    centres: list[list[float]] = field(default_factory=list)
    final_qpos: list[float] = field(default_factory=list)


def _mujoco() -> Any:
    import mujoco

    return mujoco


def _runs(wire_map: WireMap) -> list[tuple[tuple[int, int], tuple[int, int]]]:
    """The path's straight runs as (first pixel, last pixel)."""
    path = wire_map.path
    runs = []
    begin = 0
    for i in range(1, len(path) - 1):
        d1 = (path[i][0] - path[i - 1][0], path[i][1] - path[i - 1][1])
        d2 = (path[i + 1][0] - path[i][0], path[i + 1][1] - path[i][1])
        if d1 != d2:
            runs.append((path[begin], path[i]))
            begin = i
    runs.append((path[begin], path[-1]))
    return runs


def _palm_at_home(spec: Any, palm: str) -> tuple[np.ndarray, np.ndarray]:
    """The palm body's world position and rotation in the ``home`` keyframe."""
    mujoco = _mujoco()
    base = spec.compile()
    data = mujoco.MjData(base)
    mujoco.mj_resetDataKeyframe(base, data, base.key("home").id)
    mujoco.mj_forward(base, data)
    return data.body(palm).xpos.copy(), data.body(palm).xmat.reshape(3, 3).copy()


def _add_loop(palm: Any, palm_mat: np.ndarray, cfg: SceneConfig) -> int:
    """The loop on the palm: its centre site, a ring of capsules and the handle. The ring's segment count."""
    mujoco = _mujoco()
    # The ring's frame: x along the loop's horizontal diameter, z down (like the palm in the home pose).
    site_world = np.diag([1.0, -1.0, -1.0])
    local_rot = palm_mat.T @ site_world
    local_pos = palm_mat.T @ np.array([0.0, 0.0, -cfg.drop])
    quat = np.zeros(4)
    mujoco.mju_mat2Quat(quat, local_rot.ravel())
    palm.add_site(name=SITE, pos=local_pos, quat=quat, size=[0.003, 0, 0], group=4)

    def to_palm(point: np.ndarray) -> np.ndarray:
        return local_pos + local_rot @ point

    ring_rgba = [0.85, 0.55, 0.1, 1.0]
    segments = 24
    points = [
        np.array([cfg.ring_radius * math.cos(a), 0.0, cfg.ring_radius * math.sin(a)])
        for a in np.linspace(0.0, 2 * math.pi, segments + 1)
    ]
    for i in range(segments):
        palm.add_geom(
            name=f"wireloop_ring_{i}",
            type=mujoco.mjtGeom.mjGEOM_CAPSULE,
            fromto=np.concatenate([to_palm(points[i]), to_palm(points[i + 1])]),
            size=[cfg.tube_radius, 0, 0],
            contype=WIRE_BITS,
            conaffinity=WIRE_BITS,
            mass=0.002,
            rgba=ring_rgba,
        )
    # The handle: from the ring's top up to the fingers (it collides with nothing).
    palm.add_geom(
        name="wireloop_handle",
        type=mujoco.mjtGeom.mjGEOM_CAPSULE,
        fromto=np.concatenate([to_palm(np.array([0, 0, -cfg.ring_radius])), to_palm(np.array([0, 0, -0.18]))]),
        size=[0.003, 0, 0],
        contype=0,
        conaffinity=0,
        mass=0.02,
        rgba=ring_rgba,
    )
    return segments


def _add_trace(spec: Any, markers: list[list[float]]) -> None:
    """The ring centre's path (``markers``, world points) as thin capsules just above the wire."""
    mujoco = _mujoco()
    for i, (a, b) in enumerate(zip(markers, markers[1:])):
        spec.worldbody.add_geom(
            name=f"wireloop_trace_{i}",
            type=mujoco.mjtGeom.mjGEOM_CAPSULE,
            fromto=np.array(a + b) + np.array([0, 0, 0.004, 0, 0, 0.004]),  # drawn just above the wire
            size=[0.0007, 0, 0],
            contype=0,
            conaffinity=0,
            group=2,
            rgba=[0.1, 0.4, 0.9, 1.0],
        )


class Scene:
    """The extended model and the grid-to-world mapping."""

    def __init__(
        self,
        wire_map: WireMap,
        config: SceneConfig | None = None,
        markers: list[list[float]] | None = None,
        picture: bool = False,
    ) -> None:
        from svhdesc.model import get

        mujoco = _mujoco()
        self.map = wire_map
        self.config = cfg = config or SceneConfig()
        built = get(cfg.variant)
        hand = built.hand
        if hand is None or hand.prefix is None:
            raise SvhdescError(f"{cfg.variant}: the built model names no hand prefix (its manifest's hand)")
        palm = hand.name(PALM)
        spec = mujoco.MjSpec.from_file(str(built.scene_path))
        # Where the palm is in the home pose decides where the wire goes (below it, centred).
        palm_pos, palm_mat = _palm_at_home(spec, palm)
        self.height = float(palm_pos[2] - cfg.drop)
        rows = [r for r, _ in wire_map.path]
        cols = [c for _, c in wire_map.path]
        self.centre_rc = ((min(rows) + max(rows)) / 2.0, (min(cols) + max(cols)) / 2.0)
        self.centre_xy = (float(palm_pos[0]), float(palm_pos[1]))
        for body in spec.bodies:
            body.gravcomp = 1.0
        segments = _add_loop(spec.body(palm), palm_mat, cfg)
        runs = _runs(wire_map)
        for i, (first, last) in enumerate(runs):
            spec.worldbody.add_geom(
                name=f"wireloop_wire_{i}",
                type=mujoco.mjtGeom.mjGEOM_CAPSULE,
                fromto=np.concatenate([self.world(*first), self.world(*last)]),
                size=[cfg.wire_radius, 0, 0],
                contype=WIRE_BITS | 1,
                conaffinity=WIRE_BITS | 1,
                rgba=[0.15, 0.15, 0.15, 1.0],
            )
        _add_trace(spec, markers or [])
        if picture:
            stage(spec)  # the pictures' light backdrop, floor and lights
        self.model = spec.compile()
        self.site = self.model.site(SITE).id
        self.ring = {self.model.geom(f"wireloop_ring_{i}").id for i in range(segments)}
        self.wire = {self.model.geom(f"wireloop_wire_{i}").id for i in range(len(runs))}
        self.wire_segments = [
            (self.model.geom(f"wireloop_wire_{i}").id, self.world(*a), self.world(*b)) for i, (a, b) in enumerate(runs)
        ]
        self.ring_ids = sorted(self.ring)
        # The arm's servos: every joint actuator that is not the hand's.
        joint_of = [int(self.model.actuator_trnid[a, 0]) for a in range(self.model.nu)]
        self.arm_actuators = np.array([a for a, j in enumerate(joint_of) if not hand.owns(self.model.joint(j).name)])
        self.arm_dofs = np.array([self.model.jnt_dofadr[joint_of[a]] for a in self.arm_actuators])
        self.arm_qpos = np.array([self.model.jnt_qposadr[joint_of[a]] for a in self.arm_actuators])
        self.home = self.model.key("home").id

    def world(self, row: float, col: float) -> np.ndarray:
        """A map pixel's centre in the world, at the wire's height (map up = world +y)."""
        s = self.config.pixel
        return np.array(
            [
                self.centre_xy[0] + (col - self.centre_rc[1]) * s,
                self.centre_xy[1] - (row - self.centre_rc[0]) * s,
                self.height,
            ]
        )


def target_rotation(yaw: float) -> np.ndarray:
    """The ring frame for a loop at ``yaw`` (rad, counter-clockwise seen from above): x along it, z down."""
    c, s = math.cos(yaw), math.sin(yaw)
    return np.array([[c, s, 0.0], [s, -c, 0.0], [0.0, 0.0, -1.0]])


def solve_ik(
    scene: Scene, data: Any, position: np.ndarray, rotation: np.ndarray, iterations: int = 50, damping: float = 1e-2
) -> float:
    """Damped least squares on the arm joints of ``data`` (kinematics only); returns the final error norm."""
    mujoco = _mujoco()
    model = scene.model
    jacp = np.zeros((3, model.nv))
    jacr = np.zeros((3, model.nv))
    error = np.zeros(6)
    for _ in range(iterations):
        mujoco.mj_kinematics(model, data)
        mujoco.mj_comPos(model, data)
        current = data.site_xmat[scene.site].reshape(3, 3)
        error[:3] = position - data.site_xpos[scene.site]
        error[3:] = 0.5 * sum(np.cross(current[:, i], rotation[:, i]) for i in range(3))
        if np.linalg.norm(error) < 1e-9:
            break
        mujoco.mj_jacSite(model, data, jacp, jacr, scene.site)
        jac = np.vstack([jacp, jacr])[:, scene.arm_dofs]
        step = jac.T @ np.linalg.solve(jac @ jac.T + damping**2 * np.eye(6), error)
        data.qpos[scene.arm_qpos] += step
    return float(np.linalg.norm(error))


def clearance(scene: Scene, data: Any) -> float:
    """Smallest surface distance between the ring and the wire runs near it (up to ``near``)."""
    mujoco = _mujoco()
    centre = data.site_xpos[scene.site]
    reach = scene.config.ring_radius + scene.config.near
    best = scene.config.near
    for geom, a, b in scene.wire_segments:
        t = float(np.clip((centre - a) @ (b - a) / max((b - a) @ (b - a), 1e-12), 0.0, 1.0))
        if np.linalg.norm(a + t * (b - a) - centre) > reach:
            continue
        for ring in scene.ring_ids:
            best = min(best, mujoco.mj_geomDistance(scene.model, data, ring, geom, scene.config.near, None))
    return float(best)


def plan_targets(env: Environment, codes: list[int], actions: list[int]) -> list[tuple[int, int, float]]:
    """(row, col, yaw) of the loop at the start and after each planned action; yaw accumulates (no wrap)."""
    start = env.start()
    row, col = env.row_col(start.cell)
    yaw = math.radians(45.0 * start.rotation)
    poses = [(row, col, yaw)]
    for code, action in zip(codes, actions):
        if code < 0:
            break
        row, col = env.row_col(code >> 2)
        if action == CCW:
            yaw += math.pi / 4
        elif action == CW:
            yaw -= math.pi / 4
        poses.append((row, col, yaw))
    return poses


def execute(
    wire_map: WireMap, poses: list[tuple[int, int, float]], config: SceneConfig | None = None
) -> tuple[MujocoRun, Scene]:
    """Run the poses on the robot; report contacts and tracking."""
    import time

    began = time.perf_counter()
    scene = Scene(wire_map, config)
    cfg = scene.config
    follower = _Follower.at(scene, poses[0], MujocoRun(len(poses) - 1, 0.0, False, 0, cfg.near, 0.0, 0.0, 0.0, 0.0))
    run, data = follower.run, follower.data
    ticks_per_move = max(1, round(cfg.move_s / cfg.control_dt))
    first = poses[0]
    start_pos, start_rot = scene.world(first[0], first[1]), target_rotation(first[2])
    for _ in range(max(1, round(cfg.settle_s / cfg.control_dt))):
        follower.advance(start_pos, start_rot)
    run.centres.append(data.site_xpos[scene.site].round(5).tolist())
    for (r0, c0, y0), (r1, c1, y1) in zip(poses, poses[1:]):
        a, b = scene.world(r0, c0), scene.world(r1, c1)
        for tick in range(1, ticks_per_move + 1):
            t = tick / ticks_per_move
            s = 0.5 - 0.5 * math.cos(math.pi * t)  # smooth start and stop of each move
            follower.advance(a + s * (b - a), target_rotation(y0 + s * (y1 - y0)))
        run.worst_waypoint_error_m = max(
            run.worst_waypoint_error_m, float(np.linalg.norm(data.site_xpos[scene.site] - b))
        )
        run.centres.append(data.site_xpos[scene.site].round(5).tolist())
    run.sim_s = float(data.time)
    run.final_qpos = data.qpos.tolist()
    run.wall_s = time.perf_counter() - began
    return run, scene


@dataclass
class _Follower:
    """The arm following the ring's moving target: IK each control tick, the servos commanded ahead of their
    lag, and the run's contact and tracking figures gathered on the way."""

    scene: Scene
    data: Any  # the simulation
    ik: Any  # kinematics only: the IK's own state
    run: MujocoRun
    tau: np.ndarray  # s, each arm servo's lag
    previous: np.ndarray  # the last reference (arm joints)
    substeps: int  # simulation steps per control tick

    @classmethod
    def at(cls, scene: Scene, first: tuple[int, int, float], run: MujocoRun) -> _Follower:
        """The robot at the first pose (by IK from home), the servos holding it."""
        mujoco = _mujoco()
        model = scene.model
        data = mujoco.MjData(model)
        mujoco.mj_resetDataKeyframe(model, data, scene.home)
        ik = mujoco.MjData(model)
        mujoco.mj_resetDataKeyframe(model, ik, scene.home)
        if solve_ik(scene, ik, scene.world(first[0], first[1]), target_rotation(first[2]), iterations=200) > 1e-6:
            raise SvhdescError("the wire's start is out of the arm's reach")
        data.qpos[:] = ik.qpos
        data.ctrl[scene.arm_actuators] = ik.qpos[scene.arm_qpos]
        mujoco.mj_forward(model, data)
        substeps = max(1, round(scene.config.control_dt / model.opt.timestep))
        # A position servo with damping lags a moving target by about tau = (kv + joint damping) / kp;
        # leading the command by tau times the reference velocity cancels most of that lag.
        kp = model.actuator_gainprm[scene.arm_actuators, 0]
        tau = (-model.actuator_biasprm[scene.arm_actuators, 2] + model.dof_damping[scene.arm_dofs]) / kp
        return cls(scene, data, ik, run, tau, ik.qpos[scene.arm_qpos].copy(), substeps)

    def advance(self, position: np.ndarray, rotation: np.ndarray) -> None:
        """One control tick towards the ring pose (position, rotation)."""
        scene, data, run = self.scene, self.data, self.run
        solve_ik(scene, self.ik, position, rotation, iterations=10)
        reference = self.ik.qpos[scene.arm_qpos].copy()
        data.ctrl[scene.arm_actuators] = reference + self.tau * (reference - self.previous) / scene.config.control_dt
        self.previous = reference
        run.other_wire_contacts += int(self._step())
        run.min_clearance_m = min(run.min_clearance_m, clearance(scene, data))
        actual = data.site_xmat[scene.site].reshape(3, 3)
        run.worst_position_error_m = max(
            run.worst_position_error_m, float(np.linalg.norm(data.site_xpos[scene.site] - position))
        )
        cos_yaw = float(np.clip(actual[:2, 0] @ rotation[:2, 0] / max(np.linalg.norm(actual[:2, 0]), 1e-12), -1, 1))
        run.worst_yaw_error_deg = max(run.worst_yaw_error_deg, math.degrees(math.acos(cos_yaw)))

    def _step(self) -> bool:
        """The tick's simulation steps; marks the ring penetrating the wire, and says whether anything else did."""
        mujoco, scene, data = _mujoco(), self.scene, self.data
        other = False
        for _ in range(self.substeps):
            mujoco.mj_step(scene.model, data)
            if not data.ncon:
                continue
            contacts = data.contact
            for g1, g2, dist in zip(contacts.geom1.tolist(), contacts.geom2.tolist(), contacts.dist.tolist()):
                if g1 not in scene.wire and g2 not in scene.wire:
                    continue
                if g1 in scene.ring or g2 in scene.ring:
                    self.run.touched_wire = self.run.touched_wire or dist < 0
                else:
                    other = other or dist < 0
        return other


def render(
    wire_map_file: str, run: MujocoRun, out: Path, size: tuple[int, int] = (800, 600), variant: str = VARIANT
) -> str:
    """Draw the robot in its final pose over the wire, with the ring centre's path, in a child process."""
    request = {
        "variant": variant,
        "map": wire_map_file,
        "qpos": run.final_qpos,
        "centres": run.centres,
        "out": str(out),
        "size": list(size),
    }
    out.parent.mkdir(parents=True, exist_ok=True)
    return run_child([sys.executable, "-m", "svhdesc.wireloop.mujoco_run"], stdin=json.dumps(request))


def _render_child() -> int:
    mujoco = _mujoco()
    request = json.loads(sys.stdin.read())
    config = SceneConfig(variant=request["variant"])
    scene = Scene(load_map(request["map"]), config, markers=request["centres"], picture=True)
    model = scene.model
    data = mujoco.MjData(model)
    data.qpos[:] = request["qpos"]
    mujoco.mj_forward(model, data)
    camera = mujoco.MjvCamera()
    camera.type = mujoco.mjtCamera.mjCAMERA_FREE
    wire_points = np.array([scene.world(r, c) for r, c in scene.map.path])
    low, high = wire_points.min(axis=0), wire_points.max(axis=0)
    camera.lookat[:] = (low + high) / 2 + np.array([0.0, 0.04, 0.0])
    camera.distance = 0.3 + 1.05 * float(np.max(high - low))
    # From the base's side of the wire, steeply down: map up = image up, and the arm mostly out of the way.
    camera.azimuth, camera.elevation = 90.0, -72.0
    # A wire mirrored in the floor or its shadow would read as a second wire.
    model.mat_reflectance[:] = 0.0
    model.light_castshadow[:] = 0
    draw_png(model, data, camera, Path(request["out"]), tuple(request["size"]))
    return 0


def summary(run: MujocoRun) -> dict[str, object]:
    document = asdict(run)
    document.pop("centres")
    document.pop("final_qpos")
    return document


if __name__ == "__main__":
    sys.exit(_render_child())
