"""pybullet: the URDF plus one JOINT_GEAR constraint per coupled joint (pybullet ignores <mimic>).

    robot = load_pybullet("svh_right")            # connects a DIRECT client unless given one
    p.setJointMotorControl2(robot.body, robot.joints["right_hand_Pinky"], p.POSITION_CONTROL,
                            targetPosition=0.5, force=1.0, maxVelocity=1.0,
                            physicsClientId=robot.client)
    p.stepSimulation(physicsClientId=robot.client) # j13, j17 follow through robot.constraints

Followers get their default velocity motor switched off, so only the gear drives them.
Bullet's gear constraint holds q_follower + ratio * q_leader = target; ratio = -multiplier,
target = offset.

Pitfall (pybullet 3.2.7): a POSITION_CONTROL motor without ``maxVelocity`` asks for
positionGain * error / dt and saturates at its force limit; a saturated motor on a channel makes
the solver break that channel's gears (the channel then swings by tenths of a radian). Give
channel motors ``maxVelocity`` (the URDF's velocity limit, 1 rad/s for the hand): the couplings then
hold within 2e-4 rad.

Solver: the loader raises the client's constraint solver to ``SOLVER_ITERATIONS`` (150; pybullet's default is
50, a higher setting is kept). At 50 iterations the gears hold only at small steps: at pybullet's default
1/240 s step, Thumb_Opposition, Ring and Pinky (the channels with the most geared load) stall up to 0.6 rad short
of their targets and couplings drift up to 0.1 rad. At 150 they hold within 2e-4 rad at 1/240 s and at 1 ms
(tests/loaders/test_loaders.py::test_pybullet). Calls that reset the client's engine parameters undo it.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from svhdesc.loaders._common import absolute_urdf, couplings, require

GEAR_ERP = 0.8  # fraction of the position error corrected per step: no drift, no overshoot
GEAR_MAX_FORCE = 100.0  # N m: far above the finger drives (1-2 N m), so the gear never slips
SOLVER_ITERATIONS = 150  # at least: the gears hold at pybullet's default 1/240 s step too (see above)


@dataclass
class PybulletRobot:
    client: int  # physicsClientId every call on this robot must pass
    body: int  # body unique id
    joints: dict[str, int] = field(default_factory=dict)  # joint name -> joint (= child link) index
    links: dict[str, int] = field(default_factory=dict)  # link name -> link index (-1: the base)
    constraints: dict[str, int] = field(default_factory=dict)  # coupled joint name -> gear constraint id


def load_pybullet(
    name: str = "ur5_svh_right",
    client: int | None = None,
    base_position: tuple[float, float, float] = (0.0, 0.0, 0.0),
    fixed_base: bool = True,
    gear_erp: float = GEAR_ERP,
    gear_max_force: float = GEAR_MAX_FORCE,
    solver_iterations: int = SOLVER_ITERATIONS,
) -> PybulletRobot:
    """Load the variant with the URDF's inertials (``URDF_USE_INERTIA_FROM_FILE``) and its couplings; the client's
    solver gets at least ``solver_iterations`` iterations, which the gears need at pybullet's default step."""
    p = require("pybullet", "load_pybullet")
    if client is None:
        client = p.connect(p.DIRECT)
    current = p.getPhysicsEngineParameters(physicsClientId=client)["numSolverIterations"]
    if current < solver_iterations:
        p.setPhysicsEngineParameter(numSolverIterations=solver_iterations, physicsClientId=client)
    body = p.loadURDF(
        str(absolute_urdf(name)),
        basePosition=base_position,
        useFixedBase=fixed_base,
        flags=p.URDF_USE_INERTIA_FROM_FILE,
        physicsClientId=client,
    )
    robot = PybulletRobot(client, body)
    robot.links[p.getBodyInfo(body, physicsClientId=client)[0].decode()] = -1
    for index in range(p.getNumJoints(body, physicsClientId=client)):
        info = p.getJointInfo(body, index, physicsClientId=client)
        robot.joints[info[1].decode()] = index
        robot.links[info[12].decode()] = index
    for coupling in couplings(name):
        follower, leader = robot.joints[coupling.joint], robot.joints[coupling.leader]
        p.setJointMotorControl2(body, follower, p.VELOCITY_CONTROL, force=0.0, physicsClientId=client)
        constraint = p.createConstraint(
            body,
            follower,
            body,
            leader,
            jointType=p.JOINT_GEAR,
            jointAxis=(0.0, 0.0, 1.0),
            parentFramePosition=(0.0, 0.0, 0.0),
            childFramePosition=(0.0, 0.0, 0.0),
            physicsClientId=client,
        )
        p.changeConstraint(
            constraint,
            gearRatio=-coupling.multiplier,
            relativePositionTarget=coupling.offset,
            maxForce=gear_max_force,
            erp=gear_erp,
            physicsClientId=client,
        )
        robot.constraints[coupling.joint] = constraint
    return robot
