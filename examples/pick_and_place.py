"""Pick and place, end to end, as a MoveIt user would do it against the real robot: the UR5 with the SVH hand
picks a can from a table with the validated power grasp (thumb opposed), lifts it 10 cm, carries it 30 cm, puts it
down and lets go. Every arm motion is planned with OMPL (svhdesc.plan) and every command goes through the ROS
node's action servers (scaled_pos_joint_traj_controller, right_hand_controller), exactly as to the real drivers.

    svhdesc sim ur5_svh_right --ros --scene examples/pick_and_place.yaml --track can &   # with roscore
    python examples/pick_and_place.py [--pictures DIR] [--json FILE]
    python examples/pick_and_place.py --from-json FILE --pictures DIR       # pictures of a saved run, no ROS

The grasp is the config's `power` grasp, the one `svhdesc validate` checks (keyframe `power`, object placement
in `grasps`): the thumb turns into opposition first (as the validator preshapes it), the hand comes in from the
side with its fingers horizontal, and the fingers and the thumb close round the can. The hand holds the can thumb
down: gravity pulls it towards the thumb, one of the three directions the validator holds the grasp in. The can
sits 2.5 cm nearer the thumb than the validated cylinder (SHIFT), or the opposed thumb would meet the table. Hand
goals succeed where the fastest channels stop, as SCHUNK's driver's do (it declares no goal constraints); the
example waits until the hand is still before it plans. The ring finger and the pinky close last. The can is put
down where it is in the hand (tracked, tool0 by forward kinematics), its base on the target; to let go the hand
first stops the squeeze, then opens. The can is placed within 2 cm of its target (printed). Planning ignores the
carried can (MoveIt would attach it). Documentation: docs/pick_and_place.md.
"""

from __future__ import annotations

import argparse
import datetime
import json
import math
import os
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))
sys.path.insert(0, str(REPO / "benchmarks"))

from results import cpu_model  # noqa: E402

import svhdesc  # noqa: E402
from svhdesc.errors import SvhdescError  # noqa: E402
from svhdesc.plan import Planner  # noqa: E402
from svhdesc.plan.execute import execute  # noqa: E402
from svhdesc.plan.ik import pose_matrix  # noqa: E402
from svhdesc.plan.ros1 import Ros1, ros_node  # noqa: E402
from svhdesc.sim.objects import Obstacle, load_obstacles  # noqa: E402

VARIANT = "ur5_svh_right"
SCENE = Path(__file__).with_name("pick_and_place.yaml")
OBJECT = "can"
LIFT, CARRY = 0.10, np.array([-0.30, 0.0, 0.0])
CLEAR = 0.16  # m: after letting go the hand rises this far, the opposed thumb above the can's top, then backs off
GRASP = "power"  # a grasp of the config's `grasps` (object placement) and `keyframes` (channel targets)
PRESHAPED = ("Thumb_Opposition", "Finger_Spread")  # set before the approach, as the grasp validator does
LATE = ("Ring_Finger", "Pinky")  # closed after the others
# m, hand frame: the can 2.5 cm nearer the thumb than the validated cylinder, so the hand 2.5 cm higher: at the
# validated place the preshaped thumb would reach 1.5 cm below the can's base, into the table
SHIFT = np.array([-0.025, 0.0, 0.0])
TOOL, HAND_BASE = "tool0", "right_hand_base_link"
# Tool0 orientation: fingers along world -x, palm facing +y (away from the robot), thumb down: gravity pulls the
# can towards the thumb, one of the directions the grasp validator holds it in (none pulls towards the pinky).
ROLL, PITCH, YAW = 0.0, -math.pi / 2, 0.0
APPROACH = 0.08  # m: pre-grasp stand-off, palm back along -y
PLACE_PRESS = 0.004  # m: put the can down this far into the table, so it stands when released
HAND = "right_hand_controller"
ROS = Ros1()  # where plans are executed and the joints read
START_SIM = f"svhdesc sim {VARIANT} --ros --scene examples/pick_and_place.yaml --track {OBJECT}"
SETTLED = 1e-3  # rad per 0.1 s: a hand channel this slow has stopped (at its target or on the can)
SCALING = 0.5  # velocity and acceleration scaling of every arm motion (MoveIt's request factors)


def validated_grasp() -> tuple[dict[str, float], np.ndarray]:
    """The GRASP's channel targets (every hand channel; those its keyframe does not name at 0) and where its object
    sits in tool0's frame (the grasp's hand-frame placement through the tool0 -> hand base transform)."""
    import mujoco

    built = svhdesc.get(VARIANT)
    configuration = built.configuration()
    if configuration is None:
        raise RuntimeError(f"{VARIANT}: no configuration in its manifest (build it: svhdesc build)")
    settings = configuration.settings
    posture = dict(settings.keyframes[GRASP])
    targets = {f"{settings.hand.prefix}_{c}": float(posture.get(c, 0.0)) for c in configuration.channels()}
    model = mujoco.MjModel.from_xml_path(str(built.mjcf_path))
    base = model.body(HAND_BASE)
    if model.body(int(base.parentid[0])).name != TOOL or not np.allclose(base.quat, (1.0, 0.0, 0.0, 0.0)):
        raise RuntimeError(f"{VARIANT}: {HAND_BASE} is not on {TOOL} without rotation")
    return targets, base.pos + np.array(settings.grasps[GRASP]["pos"]) + SHIFT


def tool_pose(object_centre: np.ndarray, held: np.ndarray) -> tuple[float, ...]:
    """tool0 pose that puts ``object_centre`` at ``held`` in the tool frame."""
    rotation = pose_matrix((0.0, 0.0, 0.0, ROLL, PITCH, YAW))[:3, :3]
    return (*(object_centre - rotation @ held).tolist(), ROLL, PITCH, YAW)


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
        self.targets, self.held = validated_grasp()

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
        self.moments.append({"name": name, "joints": ROS.positions(), "object": self.object_pose()})

    def move(self, planner: Planner, centre: np.ndarray, label: str, held: np.ndarray | None = None) -> None:
        """Plan and execute tool0 to where the can's centre is at ``centre`` when at ``held`` in the tool frame
        (default: where the grasp puts it)."""
        config = planner.config
        here = {j: v for j, v in ROS.positions().items() if j not in config.passive}
        plan = planner.plan(
            "manipulator",
            here,
            pose=tool_pose(centre, self.held if held is None else held),
            velocity_scaling=SCALING,
            acceleration_scaling=SCALING,
        )
        if not plan.success:
            raise RuntimeError(f"{label}: no plan ({plan.message})")
        run = execute(plan, config.controllers, ROS)
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
        self.settle(list(targets))

    def settle(self, joints: list[str], timeout: float = 5.0) -> None:
        """Wait until ``joints`` stop moving (sim time): the hand's goal succeeds as its fastest channels arrive,
        the thumb's opposition takes about a second more, and a plan must start from where the hand will be."""
        last = None
        deadline = self.rospy.get_time() + timeout
        while self.rospy.get_time() < deadline:
            positions = ROS.positions()
            now = np.array([positions[j] for j in joints])
            if last is not None and np.max(np.abs(now - last)) < SETTLED:
                return
            last = now
            self.rospy.sleep(0.1)
        raise RuntimeError(f"the hand still moves {timeout} s after its goal")

    def run(self) -> dict[str, Any]:
        start = self.object_position()
        target = start + CARRY
        with_can = Planner(VARIANT, [self.table, Obstacle(OBJECT, self.can.shape, self.can.size, tuple(start))])
        table_only = Planner(VARIANT, [self.table])  # the can is grasped or carried: MoveIt would attach it
        preshape = {j: v if j.endswith(PRESHAPED) else 0.0 for j, v in self.targets.items()}
        self.moment("start")
        self.hand(preshape, 1.0)  # the thumb turns into opposition before the hand comes near the can
        self.move(with_can, start - np.array([0.0, APPROACH, 0.0]), "pre-grasp")
        self.move(table_only, start, "approach")
        # The ring finger and the pinky last: closing together at the channels' ramped rates, the ring finger meets
        # the middle finger (the opposed thumb folds the palm) and stops it at 0.07 rad, short of the can.
        self.hand({j: 0.0 if j.endswith(LATE) else v for j, v in self.targets.items()}, 1.5)
        self.hand(self.targets, 1.0)
        self.moment("grasp")
        self.move(table_only, start + np.array([0.0, 0.0, LIFT]), "lift 10 cm")
        self.moment("lifted")
        self.move(table_only, start + CARRY + np.array([0.0, 0.0, LIFT]), "carry 30 cm")
        self.moment("carried")
        # Down to where the can is in the hand now, as MoveIt would place an attached object: the fingers pull it in
        # and tilt it as they close, and released, it stands up on its base, so its base goes onto the target.
        held, axis = in_tool(table_only, self.moments[-1]), can_axis(self.moments[-1]["object"][3:])
        base_on_target = target + self.can.size[1] * (axis - np.array([0.0, 0.0, 1.0]))
        self.move(table_only, base_on_target - np.array([0.0, 0.0, PLACE_PRESS]), "put down", held)
        # Let go: first stop squeezing (a goal where the fingers stopped on the can), then open to the preshape, the
        # thumb unflexed and still opposed. Opening from the squeeze flings the can 2 cm towards the palm.
        positions = ROS.positions()
        self.hand({j: positions[j] for j in self.targets}, 0.5)
        self.hand(preshape, 1.0)
        self.move(table_only, target + np.array([0.0, 0.0, CLEAR]), "up")  # slide off the can upwards first
        placed = self.object_position()
        around = Planner(VARIANT, [self.table, Obstacle(OBJECT, self.can.shape, self.can.size, tuple(placed))])
        self.move(around, target + np.array([0.0, -APPROACH, CLEAR]), "retreat")
        self.moment("placed")
        final = self.object_position()
        error = float(np.linalg.norm(final[:2] - target[:2]))
        report = {
            "grasp": GRASP,
            "hand_targets": self.targets,
            "held_in_tool": self.held.tolist(),
            "start": start.tolist(),
            "target": target.tolist(),
            "final": final.tolist(),
            "placement_error": error,
            "height_change": float(final[2] - start[2]),
            "slip_in_hand": slip_in_hand(table_only, self.moments),
            "steps": self.log,
            "moments": self.moments,
        }
        if self.pictures is not None:
            report["pictures"] = [str(p) for p in render_moments(self.moments, self.pictures)]
        return report


def can_axis(quaternion: list[float]) -> np.ndarray:
    """The can's axis in the world (its z axis rotated by the tracked quaternion w, x, y, z)."""
    w, x, y, z = quaternion
    return np.array([2 * (x * z + w * y), 2 * (y * z - w * x), 1 - 2 * (x * x + y * y)])


def in_tool(planner: Planner, moment: dict[str, Any]) -> np.ndarray:
    """Where the can was in tool0's frame at ``moment`` (m), tool0 posed from the recorded joints (pinocchio, the
    URDF)."""
    tool = planner.kinematics().tip_pose("manipulator", moment["joints"])
    return tool[:3, :3].T @ (np.array(moment["object"][:3]) - tool[:3, 3])


def slip_in_hand(planner: Planner, moments: list[dict[str, Any]]) -> float:
    """How far the can moved in tool0's frame from the grasp to the end of the carry (m)."""
    at = {moment["name"]: in_tool(planner, moment) for moment in moments}
    return float(max(np.linalg.norm(at[name] - at["grasp"]) for name in ("lifted", "carried")))


def render_moments(moments: list[dict[str, Any]], out: Path) -> list[Path]:
    """A PNG per moment (pick_and_place_<moment>.png): the scene with the objects, posed from /joint_states and
    the tracked can, every picture from one camera; and the grasp close up (pick_and_place_hand.png)."""
    import tempfile

    import mujoco

    from svhdesc.sim.objects import add_objects
    from svhdesc.validate.render import render_many

    model_dir = svhdesc.get(VARIANT).directory
    spec = mujoco.MjSpec.from_file(str(model_dir / "scene.xml"))
    spec.meshdir = str(model_dir / "assets")
    add_objects(spec, load_obstacles(SCENE))
    model = spec.compile()
    for moment in moments:
        qpos = model.qpos0.copy()
        for name, value in moment["joints"].items():
            qpos[model.joint(name).qposadr[0]] = value
        free = model.joint(f"{OBJECT}_free").qposadr[0]
        qpos[free : free + 7] = moment["object"]
        spec.add_key(name=moment["name"], qpos=qpos.tolist())
    pictures = [(moment["name"], out / f"pick_and_place_{moment['name']}.png") for moment in moments]
    closeup = out / "pick_and_place_hand.png"
    with tempfile.TemporaryDirectory() as folder:
        scene = Path(folder) / "pick_and_place.xml"
        scene.write_text(spec.to_xml())
        render_many(scene, pictures, (640, 480), view=(-60.0, -20.0))  # from beyond the table: palm, thumb and can
        if "grasp" in {moment["name"] for moment in moments}:  # the hand on the can, from the palm's side
            render_many(scene, [("grasp", closeup)], (640, 480), view=(-120.0, -15.0), focus=(HAND_BASE, OBJECT))
            pictures.append(("grasp", closeup))
    return [path for _, path in pictures]


def markdown(report: dict[str, Any]) -> str:
    """The run's figures as a Markdown page (docs/results/pick_and_place.md)."""
    moment = {m["name"]: np.array(m["object"][:3]) for m in report["moments"]}
    thumb = next(j for j in report["hand_targets"] if j.endswith("Thumb_Opposition"))
    held = next(m["joints"][thumb] for m in report["moments"] if m["name"] == "grasp")
    rows = [
        (
            "grasp",
            f"`{report['grasp']}`: thumb opposition {report['hand_targets'][thumb]:.3f} rad, {held:.3f} at the grasp",
        ),
        ("can placed from its target", f"{100 * report['placement_error']:.1f} cm (the test's bound: 2 cm)"),
        ("height change, start to placed", f"{100 * report['height_change']:+.1f} cm"),
        ("lifted (asked 10 cm)", f"{100 * (moment['lifted'][2] - moment['start'][2]):.1f} cm"),
        ("carried (asked 30 cm)", f"{100 * (moment['start'][0] - moment['carried'][0]):.1f} cm"),
        ("slip in the hand, grasp to end of carry", f"{1000 * report['slip_in_hand']:.1f} mm"),
    ]
    lines = [
        "# Pick and place: the last run's figures",
        "",
        "- command: `python examples/pick_and_place.py --json docs/results/pick_and_place.json "
        "--markdown docs/results/pick_and_place.md`",
        f"- machine: {report.get('machine', 'not recorded')}",
        f"- date: {report.get('date', 'not recorded (rerun the command)')}",
        "",
        "How the example runs: [docs/pick_and_place.md](/docs/pick_and_place.md).",
        "",
        "| figure | value |",
        "|---|---|",
        *(f"| {name} | {value} |" for name, value in rows),
        "",
        "Arm motions (planning time varies with the machine):",
        "",
        *(f"- {step}" for step in report["steps"]),
    ]
    return "\n".join(lines) + "\n"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--pictures", type=Path, default=None, help="write a PNG per key moment here")
    parser.add_argument("--json", type=Path, default=None, help="write the report here")
    parser.add_argument("--markdown", type=Path, default=None, help="write the figures as Markdown here")
    parser.add_argument("--from-json", type=Path, default=None, help="draw the pictures of this saved report (no ROS)")
    args = parser.parse_args()
    if args.from_json is not None:
        if args.pictures is None and args.markdown is None:
            parser.error("--from-json needs --pictures DIR or --markdown FILE")
        report = json.loads(args.from_json.read_text())
        for path in render_moments(report["moments"], args.pictures) if args.pictures else ():
            print(f"wrote {path}")
        if args.markdown is not None:
            args.markdown.write_text(markdown(report))
        return
    began = time.perf_counter()
    try:
        report = PickAndPlace(args.pictures).run()
    except SvhdescError as exc:  # no master, no simulation, no ROS: one line saying what to start, no traceback
        if str(exc).startswith("no ROS master"):  # ros_node's line, with this example's scene
            exc = SvhdescError(f"{str(exc).partition(': start')[0]}: start roscore, then {START_SIM}")
        print(f"error: {exc}", file=sys.stderr)
        sys.exit(2)
    report["date"] = datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d %H:%M UTC")
    report["machine"] = f"{cpu_model()}, {os.cpu_count()} cores"
    for line in report["steps"]:
        print(line)
    print(
        f"{report['grasp']} grasp: can placed {100 * report['placement_error']:.1f} cm from its target "
        f"(height change {100 * report['height_change']:+.1f} cm), slip in the hand "
        f"{1000 * report['slip_in_hand']:.1f} mm, {time.perf_counter() - began:.1f} s wall"
    )
    for path, text in ((args.json, json.dumps(report, indent=1) + "\n"), (args.markdown, markdown(report))):
        if path is not None:
            path.parent.mkdir(parents=True, exist_ok=True)
            path.write_text(text)


if __name__ == "__main__":
    main()
