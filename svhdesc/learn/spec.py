"""A task as data: its scene, actions, observation, reward and termination terms, resets and randomisation.

In the manner of mjlab's and Isaac Lab's manager-based tasks, a task module declares a ``Task``; ``TaskEnv`` runs any
of them over any physics backend. Terms are functions of the running environment (``svhdesc.learn.env.TaskEnv``) that
return one row per world, so the same term serves the batch on a GPU and MuJoCo C on a laptop.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

Term = Callable[[Any], Any]  # TaskEnv -> tensor [nenv, ...]
ResetFn = Callable[[Any, Any], None]  # (TaskEnv, world indices) -> None


@dataclass(frozen=True)
class Obs:
    """One observation term: ``fn`` gives [nenv, k]; ``noise`` the half-width of the uniform noise the actor sees;
    ``sensed`` terms reach the actor through the sensing latency (what a real sensor or tracker reports late)."""

    name: str
    fn: Term
    noise: float = 0.0
    sensed: bool = False


@dataclass(frozen=True)
class Reward:
    """One reward term: ``fn`` gives [nenv]; the step's reward is the weighted sum times the control period."""

    name: str
    fn: Term
    weight: float


@dataclass(frozen=True)
class Done:
    """One termination term: ``fn`` gives a bool [nenv]; a ``time_out`` ends an episode without failing it."""

    name: str
    fn: Term
    time_out: bool = False


@dataclass(frozen=True)
class Shape:
    """An object the task adds: ``kind`` box, cylinder or sphere, with its nominal MuJoCo half-sizes (m)."""

    name: str
    kind: str
    size: tuple[float, float, float]
    mass: float
    rgba: tuple[float, float, float, float] = (0.85, 0.45, 0.1, 1.0)


@dataclass(frozen=True)
class Scene:
    """What ``svhdesc.learn.scene.compose`` builds around a variant's model.

    ``base_pose``: position and quaternion (w, x, y, z) of the robot's fixed base; ``objects``: free bodies;
    ``table``: half-sizes and centre of a static box, if any; ``physics_dt``: the step (s); ``nconmax``/``njmax``:
    Warp's per-world capacities for this scene (the variant's own do not count the objects)."""

    variant: str
    base_pose: tuple[tuple[float, float, float], tuple[float, float, float, float]] = ((0, 0, 0), (1, 0, 0, 0))
    objects: tuple[Shape, ...] = ()
    table: tuple[tuple[float, float, float], tuple[float, float, float]] | None = None
    physics_dt: float = 0.002
    contacts: bool = True  # False: no contact at all (a task with nothing to touch)
    nconmax: int = 160
    njmax: int = 192


@dataclass(frozen=True)
class Actions:
    """Servo targets = ``default`` + ``scale`` x action, clipped to each actuator's range; ``default`` maps an
    actuator name (the driver's channel names, the arm's joint names) to its target at action 0 (others: 0)."""

    scale: float
    default: dict[str, float] = field(default_factory=dict)
    arm_scale: float | None = None  # the arm's joints, where they differ
    # The SVH firmware moves a channel's setpoint toward the command at most at the channel's velocity limit
    # (the URDF's <limit velocity>), as svhdesc's simulation node does; an arm's joints move no faster than theirs.
    # Here once per control period.
    ramp: bool = True


@dataclass(frozen=True)
class Randomisation:
    """Ranges drawn per world at each reset (uniform): multipliers on the nominal values, or absolute ranges."""

    object_scale: tuple[float, float] = (1.0, 1.0)  # size
    object_mass: tuple[float, float] | None = None  # kg; None: the shape's mass x size^3
    object_friction: tuple[float, float] = (1.0, 1.0)  # sliding friction coefficient
    servo_gain: tuple[float, float] = (1.0, 1.0)  # x kp and kv of every servo
    joint_damping: tuple[float, float] = (1.0, 1.0)  # x every joint's damping
    latency: tuple[int, int] = (0, 0)  # control periods the sensed observations lag
    noise: float = 1.0  # x every observation term's noise


@dataclass(frozen=True)
class Training:
    """PPO settings for rsl-rl (``svhdesc.learn.train``)."""

    steps_per_env: int = 24
    hidden: tuple[int, ...] = (256, 128, 64)
    learning_rate: float = 1e-3
    entropy: float = 0.005
    epochs: int = 5
    minibatches: int = 4
    gamma: float = 0.99
    init_noise: float = 1.0
    envs: int = 4096  # the default --envs on a GPU


@dataclass(frozen=True)
class Task:
    """A learning task: see the module docstring."""

    name: str
    summary: str
    scene: Scene
    control_hz: float
    episode_s: float
    actions: Actions
    actor: tuple[Obs, ...]
    critic: tuple[Obs, ...]
    rewards: tuple[Reward, ...]
    dones: tuple[Done, ...]
    reset: ResetFn
    success: Term  # bool [nenv] at the end of an episode
    update: Callable[[Any], None] | None = None  # after each control step's physics, before rewards (task state)
    randomisation: Randomisation = Randomisation()
    training: Training = Training()
    score: Term | None = None  # a task's own figure per episode (e.g. the cube's yaw rate), for reports
    score_name: str = ""
    markers: Term | None = None  # [nenv, k, 3] points a picture shows as small green spheres (targets)
    # The picture's free camera: look-at point (m), distance (m), azimuth and elevation (degrees)
    camera: tuple[tuple[float, float, float], float, float, float] = ((0.0, 0.0, 0.1), 0.5, 135.0, -25.0)
