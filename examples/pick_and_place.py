"""Pick and place, end to end, as a MoveIt user would do it against the real robot: the UR5 with the SVH hand
picks a can from a table with a power grasp, lifts it 10 cm, carries it 30 cm, puts it down and lets go.
Every arm motion is planned with OMPL (svhdesc.plan) and every command goes through the ROS node's action
servers (scaled_pos_joint_traj_controller, right_hand_controller), exactly as to the real drivers.

    svhdesc sim ur5_svh_right --ros --scene examples/pick_and_place.yaml --track can &   # with roscore
    python examples/pick_and_place.py [--pictures DIR] [--json FILE]

The grasp: a power grasp from the side: the hand comes in with its fingers horizontal and wraps the can
against the palm; the thumb, barely opposed (0.3 of its 0.99 rad), presses on it from above. The thumb
arrives about 1 s after the hand goal's 1.5 s: the simulation ramps each setpoint at the channel's velocity
limit as SCHUNK's firmware does, and, as on the robot, the goal succeeds without waiting for it (the driver
declares no goal constraints). The can is placed within 2 cm of its
target (printed). Planning ignores the carried can (MoveIt would attach it to the hand).
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from svhdesc.errors import SvhdescError  # noqa: E402
from svhdesc.plan import Planner  # noqa: E402
from svhdesc.plan.execute import current_positions, execute, ros_node  # noqa: E402
from svhdesc.sim.objects import Obstacle, load_obstacles  # noqa: E402

VARIANT = "ur5_svh_right"
SCENE = Path(__file__).with_name("pick_and_place.yaml")
OBJECT = "can"
LIFT, CARRY = 0.10, np.array([-0.30, 0.0, 0.0])
# Where the can sits in the tool frame (tool0) when held: in front of the palm (+y), at the finger roots (+z).
HELD = np.array([0.02, 0.035, 0.13])
# Tool0 orientation: fingers along world +x, palm facing +y (away from the robot), thumb up.
ROLL, PITCH, YAW = 0.0, math.pi / 2, 0.0
APPROACH = 0.08  # m: pre-grasp stand-off, palm back along -y
PLACE_PRESS = 0.004  # m: put the can down this far into the table, so it stands when released
HAND = "right_hand_controller"
START_SIM = f"svhdesc sim {VARIANT} --ros --scene examples/pick_and_place.yaml --track {OBJECT}"
POWER_GRASP = {  # channel targets beyond contact: the servos squeeze until their force limits
    "right_hand_Index_Finger_Proximal": 0.79,
    "right_hand_Index_Finger_Distal": 1.33,
    "right_hand_Middle_Finger_Proximal": 0.79,
    "right_hand_Middle_Finger_Distal": 1.33,
    "right_hand_Ring_Finger": 0.98,
    "right_hand_Pinky": 0.98,
    "right_hand_Thumb_Flexion": 0.97,
    "right_hand_Thumb_Opposition": 0.3,
}
SCALING = 0.5  # velocity and acceleration scaling of every arm motion (MoveIt's request factors)


def tool_pose(object_centre: np.ndarray) -> tuple[float, ...]:
    """tool0 pose that puts ``object_centre`` at HELD in the tool frame (R = Ry(pi/2): (x, y, z) -> (z, y, -x))."""
    x, y, z = HELD
    tool = object_centre - np.array([z, y, -x])
    return (*tool.tolist(), ROLL, PITCH, YAW)


class PickAndPlace:
    def __init__(self, pictures: Path | None = None) -> None:
        self.rospy = ros_node()
        import rosgraph

        topics = {topic for topic, _ in rosgraph.Master("/pick_and_place").getPublishedTopics("")}
        if f"/tracked/{OBJECT}" not in topics:
            raise SvhdescError(f"the simulation is not running (no /tracked/{OBJECT} topic): start {START_SIM}")
        obstacles = load_obstacles(SCENE)
        self.table = next(o for o in obstacles if o.mass is None)
        self.can = next(o for o in obstacles if o.name == OBJECT)
        self.moments: list[dict[str, Any]] = []
        self.pictures = pictures
        self.log: list[str] = []

    def object_position(self) -> np.ndarray:
        from geometry_msgs.msg import PoseStamped

        message = self.rospy.wait_for_message(f"/tracked/{OBJECT}", PoseStamped, 10)
        p = message.pose.position
        return np.array([p.x, p.y, p.z])

    def object_pose(self) -> list[float]:
        from geometry_msgs.msg import PoseStamped

        message = self.rospy.wait_for_message(f"/tracked/{OBJECT}", PoseStamped, 10)
        p, o = message.pose.position, message.pose.orientation
        return [p.x, p.y, p.z, o.w, o.x, o.y, o.z]

    def moment(self, name: str) -> None:
        self.moments.append({"name": name, "joints": current_positions(), "object": self.object_pose()})

    def move(self, planner: Planner, centre: np.ndarray, label: str) -> None:
        config = planner.config
        here = {j: v for j, v in current_positions().items() if j not in config.passive}
        plan = planner.plan(
            "manipulator",
            here,
            pose=tool_pose(centre),
            velocity_scaling=SCALING,
            acceleration_scaling=SCALING,
        )
        if not plan.success:
            raise RuntimeError(f"{label}: no plan ({plan.message})")
        run = execute(plan, config)
        if not run.success:
            raise RuntimeError(f"{label}: execution failed {run.results}")
        self.log.append(
            f"{label}: planned in {plan.planning_time:.3f} s, {plan.duration:.1f} s motion, "
            f"tracking error {run.max_tracking_error:.4f} rad"
        )

    def hand(self, targets: dict[str, float], seconds: float) -> None:
        import actionlib
        from trajectory_msgs.msg import JointTrajectoryPoint

        from svhdesc.ros1.messages import control_msgs

        msgs = control_msgs()
        client = actionlib.SimpleActionClient(f"/{HAND}/follow_joint_trajectory", msgs.FollowJointTrajectoryAction)
        client.wait_for_server(self.rospy.Duration(20))
        goal = msgs.FollowJointTrajectoryGoal()
        goal.trajectory.joint_names = list(targets)
        goal.trajectory.points = [
            JointTrajectoryPoint(positions=list(targets.values()), time_from_start=self.rospy.Duration(seconds))
        ]
        client.send_goal(goal)
        client.wait_for_result(self.rospy.Duration(seconds + 30))
        result = client.get_result()
        if result is None or result.error_code != 0:  # SCHUNK's controller: SUCCEEDED where the fingers stop
            raise RuntimeError(f"hand goal failed: {result}")
        self.rospy.sleep(0.5)

    def run(self) -> dict[str, Any]:
        start = self.object_position()
        target = start + CARRY
        with_can = Planner(VARIANT, [self.table, Obstacle(OBJECT, self.can.shape, self.can.size, tuple(start))])
        table_only = Planner(VARIANT, [self.table])  # the can is grasped or carried: MoveIt would attach it
        self.moment("start")
        self.move(with_can, start - np.array([0.0, APPROACH, 0.0]), "pre-grasp")
        self.move(table_only, start, "approach")
        self.hand(POWER_GRASP, 1.5)
        self.moment("grasp")
        self.move(table_only, start + np.array([0.0, 0.0, LIFT]), "lift 10 cm")
        self.moment("lifted")
        self.move(table_only, start + CARRY + np.array([0.0, 0.0, LIFT]), "carry 30 cm")
        self.moment("carried")
        self.move(table_only, target - np.array([0.0, 0.0, PLACE_PRESS]), "put down")
        self.hand(dict.fromkeys(POWER_GRASP, 0.0), 1.0)
        self.move(table_only, target + np.array([0.0, 0.0, LIFT]), "up")  # slide off the can upwards first
        placed = self.object_position()
        around = Planner(VARIANT, [self.table, Obstacle(OBJECT, self.can.shape, self.can.size, tuple(placed))])
        self.move(around, target + np.array([0.0, -APPROACH, LIFT]), "retreat")
        self.moment("placed")
        final = self.object_position()
        error = float(np.linalg.norm(final[:2] - target[:2]))
        report = {
            "start": start.tolist(),
            "target": target.tolist(),
            "final": final.tolist(),
            "placement_error": error,
            "height_change": float(final[2] - start[2]),
            "steps": self.log,
            "moments": self.moments,
        }
        if self.pictures is not None:
            report["pictures"] = [str(p) for p in render_moments(self.moments, self.pictures)]
        return report


def render_moments(moments: list[dict[str, Any]], out: Path) -> list[Path]:
    """A PNG per moment: the scene with the objects, posed from /joint_states and the tracked can."""
    import tempfile

    import mujoco

    import svhdesc
    from svhdesc.sim.objects import add_objects
    from svhdesc.validate.render import render

    model_dir = svhdesc.get(VARIANT).directory
    spec = mujoco.MjSpec.from_file(str(model_dir / "scene.xml"))
    spec.meshdir = str(model_dir / "assets")
    add_objects(spec, load_obstacles(SCENE))
    spec.visual.global_.azimuth, spec.visual.global_.elevation = 235.0, -25.0  # from the front left: palm and can
    model = spec.compile()
    for moment in moments:
        qpos = model.qpos0.copy()
        for name, value in moment["joints"].items():
            qpos[model.joint(name).qposadr[0]] = value
        free = model.joint(f"{OBJECT}_free").qposadr[0]
        qpos[free : free + 7] = moment["object"]
        spec.add_key(name=moment["name"], qpos=qpos.tolist())
    out.mkdir(parents=True, exist_ok=True)
    written = []
    with tempfile.TemporaryDirectory() as folder:
        scene = Path(folder) / "pick_and_place.xml"
        scene.write_text(spec.to_xml())
        for moment in moments:
            path = out / f"pick_and_place_{moment['name']}.png"
            render(scene, path, moment["name"], (640, 480))
            written.append(path)
    return written


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--pictures", type=Path, default=None, help="write a PNG per key moment here")
    parser.add_argument("--json", type=Path, default=None, help="write the report here")
    args = parser.parse_args()
    began = time.perf_counter()
    try:
        report = PickAndPlace(args.pictures).run()
    except SvhdescError as exc:  # no master, no simulation, no ROS: one line saying what to start, no traceback
        if str(exc).startswith("no ROS master"):  # ros_node's line, with this example's scene
            exc = SvhdescError(f"{str(exc).partition(': start')[0]}: start roscore, then {START_SIM}")
        print(f"error: {exc}", file=sys.stderr)
        sys.exit(2)
    for line in report["steps"]:
        print(line)
    print(
        f"can placed {100 * report['placement_error']:.1f} cm from its target "
        f"(height change {100 * report['height_change']:+.1f} cm), {time.perf_counter() - began:.1f} s wall"
    )
    if args.json is not None:
        args.json.write_text(json.dumps(report, indent=1) + "\n")


if __name__ == "__main__":
    main()
