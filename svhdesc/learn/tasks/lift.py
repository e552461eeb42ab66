"""``ur5_lift``: ``ur5_svh_right`` grasps an object from a table and holds it 10 cm above it for 1 s.

The object is a box, a cylinder or a sphere, 4 to 8 cm across (the cylinder 1.5 times as tall), 50 to 500 g, at a
random place and yaw on the table of ``examples/pick_and_place.yaml``. Each world holds all three shapes; the two a
world does not use float out of reach with gravity compensated (Warp cannot change a geom's type per world, and a
parked object touches nothing). The arm starts 12 cm behind the grasp of the pick-and-place example, the thumb
opposed. Rewards follow mjlab's lift task (reaching times one plus bringing, and a precise bringing term); success is
mjlab's (the object within 5 cm of its target, 10 cm above where it lay) held for the last second of the episode.
"""

from __future__ import annotations

import math
from typing import Any

import torch

from svhdesc.learn import mdp
from svhdesc.learn.spec import Actions, Done, Obs, Randomisation, Reward, Scene, Shape, Task, Training

SHAPES = (
    Shape("box", "box", (0.03, 0.03, 0.03), 0.2, (0.85, 0.45, 0.1, 1.0)),
    Shape("cylinder", "cylinder", (0.03, 0.045, 0.0), 0.2, (0.75, 0.15, 0.1, 1.0)),
    Shape("sphere", "sphere", (0.03, 0.0, 0.0), 0.2, (0.2, 0.5, 0.8, 1.0)),
)
TABLE = ((0.5, 0.3, 0.02), (0.0, 0.6, -0.22))  # half-sizes and centre: examples/pick_and_place.yaml's table
TABLE_TOP = -0.2
SPOT = (0.109, 0.599)  # where the pick-and-place example's can stands
LIFT = 0.10  # m above where the object lay
TOLERANCE = 0.05  # m: mjlab's success threshold
HOLD = 1.0  # s within it at the end of the episode
PARKED = ((2.0, 2.0, 0.5), (2.3, 2.0, 0.5), (2.6, 2.0, 0.5))  # where unused shapes float
# The tool flange's pose holding a can at SPOT (the example's grasp), 12 cm back along -y (8 cm, the example's
# stand-off, put the largest objects' surface into the fingers): solved by damped least
# squares on this model, the hand's orientation kept.
PRE_GRASP = {
    "shoulder_pan_joint": 0.7055,
    "shoulder_lift_joint": -0.5994,
    "elbow_joint": 1.6884,
    "wrist_1_joint": -1.0909,
    "wrist_2_joint": -0.8638,
    "wrist_3_joint": -4.7147,
    "Thumb_Opposition": 0.9879,
}
HELD_IN_TOOL = (-0.025, 0.052, 0.152)  # m: the example's can centre in tool0's frame when held


def grasp_point(env: Any) -> torch.Tensor:
    """Where a held object's centre sits: fixed in the tool frame (forward kinematics on the real robot)."""
    offset = torch.tensor(HELD_IN_TOOL, device=env.device).expand(env.num_envs, 3)
    return env.body_pos("tool0") + mdp.quat_rotate(env.body_quat("tool0"), offset)


def _choice(env: Any) -> torch.Tensor:
    return env.commands["shape"]


def object_pos(env: Any) -> torch.Tensor:
    """The active object's position per world."""
    stacked = torch.stack([env.object_pos(s.name) for s in SHAPES], 1)
    return stacked[torch.arange(env.num_envs, device=env.device), _choice(env)]


def object_quat(env: Any) -> torch.Tensor:
    stacked = torch.stack([env.object_quat(s.name) for s in SHAPES], 1)
    return stacked[torch.arange(env.num_envs, device=env.device), _choice(env)]


def object_vel(env: Any) -> torch.Tensor:
    stacked = torch.stack([torch.cat((env.object_linvel(s.name), env.object_angvel(s.name)), -1) for s in SHAPES], 1)
    return stacked[torch.arange(env.num_envs, device=env.device), _choice(env)]


def to_target(env: Any) -> torch.Tensor:
    return env.commands["target"] - object_pos(env)


def reset(env: Any, mask: torch.Tensor) -> None:
    r = env.task.randomisation
    n = env.num_envs
    choice = torch.randint(0, len(SHAPES), (n,), generator=env.generator, device=env.device)
    env.commands["shape"] = torch.where(mask, choice, env.commands.get("shape", choice))
    scale = env.uniform(*r.object_scale)
    mass = env.uniform(*r.object_mass) if r.object_mass is not None else torch.full((n,), 0.2, device=env.device)
    friction = env.uniform(*r.object_friction)
    place = torch.stack((SPOT[0] + env.uniform(-0.03, 0.03), SPOT[1] + env.uniform(-0.02, 0.02)), -1)
    up = torch.tensor((0.0, 0.0, 1.0), device=env.device).expand(n, 3)
    yaw = mdp.quat_from_axis_angle(up, env.uniform(-math.pi, math.pi))
    for k, shape in enumerate(SHAPES):
        mdp.resize_object(env, mask, shape, scale, mass)
        env.set_model(mask, "geom_friction", (env.geom_id(shape.name), 0), friction)
        active = env.commands["shape"] == k
        height = torch.full((n,), shape.size[2] if shape.kind == "box" else shape.size[1], device=env.device)
        height = torch.where(torch.tensor(shape.kind == "sphere", device=env.device), shape.size[0], height)
        lying = torch.cat((place, (TABLE_TOP + height * scale + 0.001).unsqueeze(-1)), -1)
        parked = torch.tensor(PARKED[k], device=env.device).expand(n, 3)
        env.set_object(mask, shape.name, torch.where(active.unsqueeze(-1), lying, parked), yaw)
        gravcomp = torch.where(active, 0.0, 1.0)
        env.set_model(mask, "body_gravcomp", env.bodies[shape.name], gravcomp)
    target = object_pos(env) + torch.tensor((0.0, 0.0, LIFT), device=env.device)
    env.commands["target"] = torch.where(mask.unsqueeze(-1), target, env.commands.get("target", target))
    held = env.commands.get("held", torch.zeros(n, device=env.device))
    env.commands["held"] = torch.where(mask, torch.zeros_like(held), held)
    env.set_joints(mask, env.default_ctrl.expand(n, -1))


def update(env: Any) -> None:
    """Seconds the object has been within the tolerance of its target, without a break."""
    near = torch.linalg.norm(to_target(env), dim=-1) < TOLERANCE
    env.commands["held"] = torch.where(near, env.commands["held"] + env.dt, torch.zeros_like(env.commands["held"]))


def _staged(env: Any) -> torch.Tensor:
    reach = torch.exp(-torch.sum((grasp_point(env) - object_pos(env)) ** 2, -1) / 0.1**2)
    bring = torch.exp(-torch.sum(to_target(env) ** 2, -1) / 0.1**2)
    return reach * (1.0 + bring)


def _precise(env: Any) -> torch.Tensor:
    return torch.exp(-torch.sum(to_target(env) ** 2, -1) / TOLERANCE**2)


def _action_rate(env: Any) -> torch.Tensor:
    return torch.square(env.action - env.previous_action).sum(-1)


def fell(env: Any) -> torch.Tensor:
    pos = object_pos(env)
    return (pos[:, 2] < TABLE_TOP - 0.05) | (
        torch.linalg.norm(pos[:, :2] - env.commands["target"][:, :2], dim=-1) > 0.3
    )


def _shape_code(env: Any) -> torch.Tensor:
    """What a tracker reports of the object: its class (one-hot) and its size (m, the shape's half-size)."""
    onehot = torch.nn.functional.one_hot(_choice(env), len(SHAPES)).float()
    geoms = [env.geom_id(s.name) for s in SHAPES]
    sizes = env.physics.model["geom_size"][:, geoms, 0]
    size = sizes[torch.arange(env.num_envs, device=env.device), _choice(env)]
    return torch.cat((onehot, size.unsqueeze(-1).float()), -1)


def _mass_friction(env: Any) -> torch.Tensor:
    model = env.physics.model
    masses = model["body_mass"][:, [env.bodies[s.name] for s in SHAPES]]
    friction = model["geom_friction"][:, [env.geom_id(s.name) for s in SHAPES], 0]
    rows = torch.arange(env.num_envs, device=env.device)
    return torch.stack((masses[rows, _choice(env)], friction[rows, _choice(env)]), -1).float()


TASK = Task(
    name="ur5_lift",
    summary="ur5_svh_right grasps a box, cylinder or sphere from a table and holds it 10 cm up for 1 s",
    # 1 ms, the model's own step: at 2 ms, 1 in 800 world-steps of random actions flung the object (> 5 m/s) and
    # MuJoCo C found a world unstable; at 1 ms none of 800 did. Capacities: about 3x the most contacts (36) and
    # constraint rows (145) MuJoCo C met in 800 world-steps of random actions.
    scene=Scene(variant="ur5_svh_right", objects=SHAPES, table=TABLE, physics_dt=0.001, nconmax=112, njmax=448),
    control_hz=25.0,
    episode_s=6.0,
    actions=Actions(scale=0.5, arm_scale=0.5, default=PRE_GRASP),
    actor=(
        Obs("joint_pos", lambda env: env.joint_pos(), noise=0.01, sensed=True),
        Obs("last_action", lambda env: env.action),
        Obs("object_pos", object_pos, noise=0.005, sensed=True),
        Obs("object_rot", lambda env: mdp.rot6d(object_quat(env)), noise=0.05, sensed=True),
        Obs("object_class", _shape_code),
        Obs("grasp_point", grasp_point),
        Obs("target", lambda env: env.commands["target"]),
    ),
    critic=(
        Obs("joint_pos", lambda env: env.joint_pos()),
        Obs("joint_vel", lambda env: env.joint_vel()),
        Obs("last_action", lambda env: env.action),
        Obs("object_pos", object_pos),
        Obs("object_rot", lambda env: mdp.rot6d(object_quat(env))),
        Obs("object_vel", object_vel),
        Obs("object_class", _shape_code),
        Obs("object_params", _mass_friction),
        Obs("grasp_point", grasp_point),
        Obs("target", lambda env: env.commands["target"]),
    ),
    rewards=(
        Reward("lift", _staged, 1.0),
        Reward("lift_precise", _precise, 1.0),
        Reward("action_rate", _action_rate, -0.01),
        Reward("fell", lambda env: fell(env).float(), -50.0),
    ),
    dones=(Done("fell", fell),),
    reset=reset,
    success=lambda env: env.commands["held"] >= HOLD - 1e-6,
    update=update,
    randomisation=Randomisation(
        object_scale=(2.0 / 3.0, 4.0 / 3.0),
        object_mass=(0.05, 0.5),
        object_friction=(0.6, 1.2),
        servo_gain=(0.8, 1.2),
        joint_damping=(0.8, 1.2),
        latency=(0, 1),
    ),
    training=Training(steps_per_env=24, hidden=(512, 256, 128), learning_rate=1e-3, entropy=0.005, envs=4096),
    score=lambda env: torch.linalg.norm(to_target(env), dim=-1) * 100.0,
    markers=lambda env: env.commands["target"].unsqueeze(1),
    camera=((0.12, 0.55, -0.15), 0.75, 200.0, -25.0),
    score_name="distance from the target (cm)",
)
