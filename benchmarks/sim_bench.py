"""Speed of the ROS node (``svhdesc sim VARIANT --ros --as-fast``) beside the bare ``mj_step`` rate.

    python benchmarks/sim_bench.py [WINDOW [VARIANT ...]]   # wall s timed per variant (default 5); default all

Per variant: (a) bare mj_step on the scene (10 simulated s), as a real-time factor at the model's timestep,
measured just before and just after (c), their mean the reference; (b) the node's simulation without ROS
(gravity compensation, the same goals, chunked as the node steps): what the runtime costs; (c) the node
as fast as it can, with every topic it publishes subscribed (so every message is serialised and sent):
/clock (100 Hz), /joint_states (50 Hz), the controllers' state (hand 50 Hz, arm 125 Hz), connector pose
topics, feedback, the fingertip wrench and one tracked body, while one goal per controller moves home -> test.
Goal (issue 25): node >= 0.8 of bare for every variant. Writes docs/results/node_speed.md. Not a test:
machines are noisy; the ratio is taken against a reference measured around it.
"""

from __future__ import annotations

import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import mujoco

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

sys.path.insert(0, str(REPO / "benchmarks"))

from results import write  # noqa: E402

import svhdesc  # noqa: E402
from svhdesc.ros1.system import import_ros  # noqa: E402
from tests.rosmaster import master, stop, wait_for  # noqa: E402

GOAL = 0.8
TRACK = {"svh_right": "right_hand_t", "svh_left": "left_hand_t", "ur5_svh_right": "tool0"}


def bare_rate(variant: str, seconds: float) -> float:
    model = svhdesc.load_mujoco(variant, scene=True)
    data = mujoco.MjData(model)
    mujoco.mj_resetDataKeyframe(model, data, model.key("home").id)
    steps = round(seconds / model.opt.timestep)
    start = time.perf_counter()
    for _ in range(steps):
        mujoco.mj_step(model, data)
    return steps * model.opt.timestep / (time.perf_counter() - start)


def runtime_rate(variant: str, seconds: float) -> float:
    """The node's simulation without ROS: the same scene (gravity compensation on), the same goals (home ->
    test over 60 s), stepped as the node steps it (chunks between the 8 and 10 ms instants, a controller
    update at each) with no callback: what the runtime costs before any message."""
    from svhdesc.sim import Point, Simulation

    sim = Simulation(variant)
    test = dict(zip(sim.info.actuators, svhdesc.load_mujoco(variant).key("test").ctrl))
    for joints in (sim.info.hand_channels, sim.info.arm_joints):
        if joints:
            sim.follow(joints, [Point(60.0, tuple(test[j] for j in joints))])
    sim.control_steps = round(0.01 / sim.timestep)  # as the node: updates at the callback instants only
    return sim.run(seconds, realtime=False, every=(0.01, 0.008))


def node_rate(variant: str, window: float, rospy: object) -> float:
    """Simulated seconds per wall second over ``window`` wall seconds, everything subscribed."""
    from rosgraph_msgs.msg import Clock  # type: ignore[import-not-found]
    from rospy import AnyMsg  # type: ignore[import-not-found]

    from svhdesc.ros1.messages import control_msgs
    from svhdesc.sim import Simulation

    info = Simulation(variant).info
    test = dict(zip(info.actuators, svhdesc.load_mujoco(variant).key("test").ctrl))
    process = subprocess.Popen(
        [
            str(Path(sys.executable).with_name("svhdesc")),
            "sim",
            variant,
            "--ros",
            "--as-fast",
            "--track",
            TRACK[variant],
        ],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    subscribers: dict[str, object] = {}
    latest: list[float] = []
    try:

        def subscribe_all() -> bool:
            for topic, _ in rospy.get_published_topics():
                # The action topics are the in-process action clients' own (rospy allows one type per topic).
                ours = "/follow_joint_trajectory/" in topic
                if topic not in subscribers and topic not in ("/rosout", "/clock") and not ours:
                    subscribers[topic] = rospy.Subscriber(topic, AnyMsg, lambda _: None, queue_size=10)
            return "/joint_states" in subscribers

        wait_for(subscribe_all, 60, "the node's topics")
        subscribers["/clock"] = rospy.Subscriber("/clock", Clock, lambda m: latest.append(m.clock.to_sec()))
        time.sleep(1.0)
        subscribe_all()
        send_goals(variant, info, test, control_msgs(), rospy)
        subscribe_all()  # the action topics now carry feedback and results
        wait_for(lambda: latest, 30, "/clock")
        sim0, wall0 = latest[-1], time.perf_counter()
        time.sleep(window)
        sim1, wall1 = latest[-1], time.perf_counter()
    finally:
        stop(process)
        for subscriber in subscribers.values():
            subscriber.unregister()
    return (sim1 - sim0) / (wall1 - wall0)


def send_goals(variant: str, info: object, test: dict[str, float], msgs: object, rospy: object) -> None:
    """One slow home -> test goal per controller, so feedback flows while the window is timed."""
    import actionlib  # type: ignore[import-not-found]
    from trajectory_msgs.msg import JointTrajectoryPoint  # type: ignore[import-not-found]

    from svhdesc.model import ARM_CONTROLLER, hand_controller

    groups = [(hand_controller(info.hand_prefix), info.hand_channels)]
    if info.arm_joints:
        groups.append((ARM_CONTROLLER, info.arm_joints))
    for controller, joints in groups:
        client = actionlib.SimpleActionClient(
            f"/{controller}/follow_joint_trajectory", msgs.FollowJointTrajectoryAction
        )
        client.wait_for_server()
        goal = msgs.FollowJointTrajectoryGoal()
        goal.trajectory.joint_names = list(joints)
        point = JointTrajectoryPoint(positions=[test[j] for j in joints], time_from_start=rospy.Duration(60.0))
        goal.trajectory.points.append(point)
        client.send_goal(goal)


def main() -> None:
    window = float(sys.argv[1]) if len(sys.argv) > 1 else 5.0
    rospy = import_ros()
    home = Path(tempfile.mkdtemp(prefix="svhdesc-bench-ros-"))
    rows = []
    with master(home) as env:
        os.environ.update(env)
        rospy.set_param("/use_sim_time", True)
        rospy.init_node("svhdesc_bench", anonymous=True, disable_signals=True)
        print(f"{'variant':<16} {'bare':>8} {'runtime':>8} {'node':>8} {'node/bare':>10} {'node/runtime':>13}")
        for variant in sys.argv[2:] or svhdesc.variants():
            before = bare_rate(variant, 10.0)
            alone = runtime_rate(variant, 10.0)
            node = node_rate(variant, window, rospy)
            bare = 0.5 * (before + bare_rate(variant, 10.0))
            rows.append((variant, bare, alone, node))
            print(f"{variant:<16} {bare:7.1f}x {alone:7.1f}x {node:7.1f}x {node / bare:10.2f} {node / alone:13.2f}")
    met = all(node / bare >= GOAL for _, bare, _, node in rows)
    body = [
        "Real-time factor of the ROS 1 node (`svhdesc sim VARIANT --ros --as-fast`) with every topic it publishes",
        "subscribed and one goal per controller executing, beside bare `mj_step` on the same scene (measured just",
        f"before and after the node, the mean of the two). The node is timed over {window:g} s of wall time.",
        "The machine is shared and loaded (see the header): absolute figures are noisy, the ratio less so.",
        "",
        "The middle column is the node's simulation without ROS (gravity compensation on, the same goals, stepped",
        "in the node's chunks with a controller update at each, no messages): what the runtime itself costs.",
        "",
        "| variant | bare `mj_step` | runtime, no ROS | ROS node | node / bare | node / runtime |",
        "|---|---|---|---|---|---|",
        *[f"| `{v}` | {b:.1f}x | {a:.1f}x | {n:.1f}x | {n / b:.2f} | {n / a:.2f} |" for v, b, a, n in rows],
        "",
        f"Goal: node / bare >= {GOAL} for every variant: **{'met' if met else 'NOT met'}** in this run.",
        "How the node steps and publishes: [docs/speed.md](/docs/speed.md#the-node-against-bare-physics).",
    ]
    path = write("node_speed", "Simulation node speed: the ROS 1 node against bare mj_step", body)
    print(f"goal: node/bare >= {GOAL} for every variant: {'met' if met else 'NOT met'}; wrote {path.relative_to(REPO)}")


if __name__ == "__main__":
    main()
