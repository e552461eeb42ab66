"""Execute a plan as MoveIt's simple controller manager does: one FollowJointTrajectory goal per controller
that moveit_controllers.yaml names for the plan's joints, sent together; the tracking error is read from
each controller's ``state`` topic (JointTrajectoryControllerState.error) while they run.
"""

from __future__ import annotations

import threading
from dataclasses import dataclass
from typing import Any

from svhdesc.errors import SvhdescError
from svhdesc.plan.config import MoveItConfig
from svhdesc.plan.planner import Plan

START_TOLERANCE = 0.01  # rad: MoveIt refuses to execute when the robot is elsewhere (allowed_start_tolerance)


@dataclass
class Execution:
    success: bool
    results: dict[str, tuple[int, str]]  # controller -> (error_code, error_string)
    max_tracking_error: float  # rad, over the execution, every joint
    final_error: float  # rad, desired end vs where the joints are after the goal ends

    def as_json(self) -> dict:
        return {
            "success": self.success,
            "results": {k: {"error_code": c, "error_string": s} for k, (c, s) in self.results.items()},
            "max_tracking_error": self.max_tracking_error,
            "final_error": self.final_error,
        }


def ros_node() -> Any:
    """rospy, with this process registered as a node (once)."""
    from svhdesc.ros1.system import import_ros

    rospy = import_ros()
    import rosgraph

    if not rosgraph.Master("/svhdesc_plan").is_online():
        raise SvhdescError(f"no ROS master at {rosgraph.get_master_uri()}: start svhdesc sim --ros first")
    if not rospy.core.is_initialized():
        rospy.init_node("svhdesc_plan", anonymous=True, disable_signals=True)
    return rospy


def current_positions(timeout: float = 10.0) -> dict[str, float]:
    rospy = ros_node()
    from sensor_msgs.msg import JointState

    message = rospy.wait_for_message("/joint_states", JointState, timeout)
    return dict(zip(message.name, message.position))


def execute(plan: Plan, config: MoveItConfig, timeout: float = 120.0) -> Execution:
    if not plan.success:
        raise SvhdescError("nothing to execute: the plan failed")
    rospy = ros_node()
    import actionlib

    from svhdesc.ros1.messages import control_msgs

    msgs = control_msgs()
    chosen = [c for c in config.controllers if set(c.joints) & set(plan.joint_names)]
    uncovered = set(plan.joint_names) - {j for c in chosen for j in c.joints}
    if uncovered:
        raise SvhdescError(f"no controller in moveit_controllers.yaml drives {sorted(uncovered)}")
    here = current_positions()
    off = {j: abs(here[j] - p) for j, p in zip(plan.joint_names, plan.positions[0])}
    worst = max(off, key=off.get)
    if off[worst] > START_TOLERANCE:
        raise SvhdescError(f"the robot is not at the plan's start: {worst} is {off[worst]:.4f} rad away")
    errors: list[float] = []
    lock = threading.Lock()

    def on_state(message: Any) -> None:
        with lock:
            errors.append(max((abs(e) for e in message.error.positions), default=0.0))

    subscribers, clients = [], {}
    for controller in chosen:
        subscribers.append(rospy.Subscriber(f"/{controller.name}/state", msgs.JointTrajectoryControllerState, on_state))
        client = actionlib.SimpleActionClient(
            f"/{controller.name}/{controller.action_ns}", msgs.FollowJointTrajectoryAction
        )
        if not client.wait_for_server(rospy.Duration(20)):
            raise SvhdescError(f"no action server /{controller.name}/{controller.action_ns}")
        clients[controller.name] = client
    try:
        for name, client in clients.items():
            client.send_goal(_goal_for(plan, config, name, msgs, rospy))
        results = {}
        for name, client in clients.items():
            if not client.wait_for_result(rospy.Duration(plan.duration + timeout)):
                client.cancel_goal()
                raise SvhdescError(f"{name}: no result within {plan.duration + timeout:.1f} s")
            result = client.get_result()
            results[name] = (int(result.error_code), result.error_string) if result else (-99, "no result")
        rospy.sleep(0.3)
    finally:
        for subscriber in subscribers:
            subscriber.unregister()
    there = current_positions()
    final = max(abs(there[j] - p) for j, p in zip(plan.joint_names, plan.positions[-1]))
    with lock:
        tracking = max(errors, default=0.0)
    return Execution(all(code == 0 for code, _ in results.values()), results, tracking, final)


def _goal_for(plan: Plan, config: MoveItConfig, controller: str, msgs: Any, rospy: Any) -> Any:
    from trajectory_msgs.msg import JointTrajectoryPoint

    joints = next(c.joints for c in config.controllers if c.name == controller)
    columns = [plan.joint_names.index(j) for j in joints if j in plan.joint_names]
    goal = msgs.FollowJointTrajectoryGoal()
    goal.trajectory.joint_names = [plan.joint_names[c] for c in columns]
    for t, p, v, a in zip(plan.times, plan.positions, plan.velocities, plan.accelerations):
        goal.trajectory.points.append(
            JointTrajectoryPoint(
                positions=[p[c] for c in columns],
                velocities=[v[c] for c in columns],
                accelerations=[a[c] for c in columns],
                time_from_start=rospy.Duration.from_sec(t),
            )
        )
    return goal
