"""``svhdesc plan --execute`` over ROS 1: rospy and actionlib to a running ``svhdesc sim --ros`` (the tracking error
from each controller's ``state`` topic, JointTrajectoryControllerState.error)."""

from __future__ import annotations

import threading
from collections.abc import Sequence
from typing import Any

from svhdesc.errors import SvhdescError
from svhdesc.plan.execute import ControllerGoal


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


class Ros1:
    """The ``Transport`` of ``svhdesc.plan.execute`` over ROS 1; joint names are the same on both sides."""

    def positions(self, timeout: float = 10.0) -> dict[str, float]:
        rospy = ros_node()
        from sensor_msgs.msg import JointState

        message = rospy.wait_for_message("/joint_states", JointState, timeout)
        return dict(zip(message.name, message.position))

    def follow(self, goals: Sequence[ControllerGoal], wait: float) -> tuple[dict[str, tuple[int, str]], float]:
        rospy = ros_node()
        import actionlib

        from svhdesc.ros1.messages import control_msgs

        msgs = control_msgs()
        errors: list[float] = []
        lock = threading.Lock()

        def on_state(message: Any) -> None:
            with lock:
                errors.append(max((abs(e) for e in message.error.positions), default=0.0))

        subscribers, clients = [], {}
        for goal in goals:
            name = goal.controller.name
            subscribers.append(rospy.Subscriber(f"/{name}/state", msgs.JointTrajectoryControllerState, on_state))
            action = f"/{name}/{goal.controller.action_ns}"
            client = actionlib.SimpleActionClient(action, msgs.FollowJointTrajectoryAction)
            if not client.wait_for_server(rospy.Duration(20)):
                raise SvhdescError(f"no action server {action}")
            clients[name] = client
        try:
            for goal in goals:
                clients[goal.controller.name].send_goal(_message(goal, msgs, rospy))
            results = {}
            for name, client in clients.items():
                if not client.wait_for_result(rospy.Duration(wait)):
                    client.cancel_goal()
                    raise SvhdescError(f"{name}: no result within {wait:.1f} s")
                result = client.get_result()
                results[name] = (int(result.error_code), result.error_string) if result else (-99, "no result")
            rospy.sleep(0.3)
        finally:
            for subscriber in subscribers:
                subscriber.unregister()
        with lock:
            return results, max(errors, default=0.0)


def _message(goal: ControllerGoal, msgs: Any, rospy: Any) -> Any:
    from trajectory_msgs.msg import JointTrajectoryPoint

    message = msgs.FollowJointTrajectoryGoal()
    message.trajectory.joint_names = list(goal.joints)
    for t, p, v, a in zip(goal.times, goal.positions, goal.velocities, goal.accelerations):
        message.trajectory.points.append(
            JointTrajectoryPoint(
                positions=list(p), velocities=list(v), accelerations=list(a), time_from_start=rospy.Duration.from_sec(t)
            )
        )
    return message
