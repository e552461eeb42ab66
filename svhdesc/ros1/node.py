"""The ROS 1 node (``svhdesc sim VARIANT --ros``): the simulation behind the real drivers' interfaces.

Topics and actions (names as SCHUNK's SVH driver and ur_robot_driver use them):
  /clock                                              rosgraph_msgs/Clock, simulated time
  /joint_states                                       sensor_msgs/JointState, every joint
  /<prefix>_controller/follow_joint_trajectory        control_msgs/FollowJointTrajectory (9 channels)
  /<prefix>_controller/command                        trajectory_msgs/JointTrajectory
  /<prefix>_controller/state, /<prefix>_controller/query_state   control_msgs JointTrajectoryControllerState
                                                      and QueryTrajectoryState
  /scaled_pos_joint_traj_controller/follow_joint_trajectory, .../command, state, query_state (6 arm joints)
  /pos_joint_traj_controller/...                      the same, loaded stopped (as ur5_bringup.launch)
  /joint_group_vel_controller/command                 std_msgs/Float64MultiArray, loaded stopped
  /<forward position controller>/command              std_msgs/Float64MultiArray, loaded stopped (arm, hand)
  /controller_manager/list_controllers, list_controller_types, switch_controller   controller_manager_msgs
  connector topics (config/connector.yaml)            std_msgs/Float64 control / pose / initpose
  /tracked/<body>                                     geometry_msgs/PoseStamped (--track)
  <F3D topicName of the URDF>                         geometry_msgs/WrenchStamped, index fingertip

All names but /clock and the connector's are relative: started in a namespace (``__ns:=left``),
the node serves there. All work on the simulation happens in one thread; ROS callbacks only queue it.
"""

from __future__ import annotations

import math
import warnings
from collections import deque
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

from lxml import etree

from svhdesc.control.goals import Tolerances
from svhdesc.control.outbox import Outbox
from svhdesc.control.trajectory import due, next_tick
from svhdesc.control.work import WORK_PER_UPDATE, drain
from svhdesc.errors import SvhdescError
from svhdesc.model import (
    ACTION_MONITOR_RATE,
    ARM_CONTROLLER,
    ARM_STOPPED_CONTROLLER,
    ARM_VELOCITY_CONTROLLER,
    CONSTRAINTS,
    CONTROLLER_TYPES,
    CONTROLLER_UPDATE_RATE,
    JOINT_STATE_CONTROLLER,
    NODE_NAME,
    REPORTS_VELOCITY,
    ROS2_FORWARD_CONTROLLER,
    ROS2_FORWARD_TYPE,
    STATE_PUBLISH_RATE,
    VELOCITY_SERVO_CONTROLLER,
    VELOCITY_SERVO_TYPE,
    hand_controller,
    ros2_hand_forward_controller,
)
from svhdesc.ros1.connector import ConnectorJoint, load_connector
from svhdesc.ros1.messages import control_msgs
from svhdesc.ros1.system import import_ros, synchronous_publisher
from svhdesc.sim import Simulation

POSITION_INTERFACE = "hardware_interface::PositionJointInterface"
STATE_INTERFACE = "hardware_interface::JointStateInterface"
VELOCITY_INTERFACE = "hardware_interface::VelocityJointInterface"

if TYPE_CHECKING:  # annotations only; the node imports them where it builds its controllers
    from svhdesc.ros1.controller import TrajectoryController
    from svhdesc.ros1.manager import Loaded
    from svhdesc.ros1.velocity import VelocityGroupController


def f3d_sensors(urdf: Path) -> list[tuple[str, str, str]]:
    """(topic, body, frame) of each Gazebo F3D plugin in the URDF: the wrench topics Gazebo would publish."""
    found = []
    for plugin in etree.parse(str(urdf)).iterfind(".//gazebo/plugin[@filename='libgazebo_ros_f3d.so']"):
        topic, body, frame = (plugin.findtext(tag) for tag in ("topicName", "bodyName", "frameName"))
        if topic and body:
            found.append((topic, body, frame or body))  # relative, as Gazebo resolves it in the robot namespace
    return found


def urdf_root(urdf: Path) -> str:
    tree = etree.parse(str(urdf))
    children = {j.get("link") for j in tree.iterfind("joint/child")}
    roots = [link.get("name") for link in tree.iterfind("link") if link.get("name") not in children]
    return roots[0] if roots else "world"


def _tolerances(rospy: Any, controller: str, joints: Sequence[str], kind: str) -> Tolerances:
    defaults = CONSTRAINTS[kind]
    base = f"{controller}/constraints"
    return Tolerances(
        path={j: float(rospy.get_param(f"{base}/{j}/trajectory", defaults["trajectory"])) for j in joints},
        goal={j: float(rospy.get_param(f"{base}/{j}/goal", defaults["goal"])) for j in joints},
        stopped_velocity=float(
            rospy.get_param(f"{base}/stopped_velocity_tolerance", defaults["stopped_velocity_tolerance"])
        ),
        goal_time=float(rospy.get_param(f"{base}/goal_time", defaults["goal_time"])),
    )


def _trajectory_groups(info: Any) -> list[tuple[str, str, list[str], bool, str, bool]]:
    """(name, type, joints, partial goals allowed, kind, running) of each trajectory controller to load."""
    groups = []
    if info.hand_channels:
        name = hand_controller(info.hand_prefix or "hand")
        groups.append((name, CONTROLLER_TYPES["hand"], info.hand_channels, True, "hand", True))
    if info.arm_joints:
        groups.append((ARM_CONTROLLER, CONTROLLER_TYPES[ARM_CONTROLLER], info.arm_joints, False, "arm", True))
        stopped = ARM_STOPPED_CONTROLLER
        groups.append((stopped, CONTROLLER_TYPES[stopped], info.arm_joints, False, "arm", False))
    return groups


class SimNode:
    def __init__(
        self,
        sim: Simulation,
        connector: Sequence[ConnectorJoint],
        track: Sequence[str],
        rate: float,
        clock_rate: float,
    ) -> None:
        rospy = import_ros()
        from geometry_msgs.msg import PoseStamped, WrenchStamped
        from rosgraph_msgs.msg import Clock
        from sensor_msgs.msg import JointState
        from std_msgs.msg import Float64

        from svhdesc.model import get
        from svhdesc.ros1.manager import ControllerManager

        self._rospy = rospy
        self.sim = sim
        self.queue: deque = deque()
        self.outbox = Outbox()
        self._period = 1.0 / rate
        self._clock_period = 1.0 / clock_rate
        urdf = get(sim.variant).urdf_path
        self._frame = urdf_root(urdf)
        msgs = control_msgs()
        self._clock = synchronous_publisher("/clock", Clock)
        self._joint_states = synchronous_publisher("joint_states", JointState)
        self._Clock, self._JointState = Clock, JointState
        self._PoseStamped, self._WrenchStamped, self._Float64 = PoseStamped, WrenchStamped, Float64
        self._tracked = [(body, synchronous_publisher(f"tracked/{body}", PoseStamped)) for body in track]
        self._wrenches = [
            (body, frame, synchronous_publisher(topic, WrenchStamped)) for topic, body, frame in f3d_sensors(urdf)
        ]
        self.controllers: list[TrajectoryController] = []
        self._velocity_controllers: list[VelocityGroupController] = []
        self.manager = ControllerManager(self._load_controllers(rospy, msgs), self.queue)
        self._pose_topics = self._connect(rospy, connector, Float64)
        self._pose_messages = [Float64() for _ in self._pose_topics]
        self._joint_state_message, self._clock_message = JointState(), Clock()
        self._drives_ros_time = self._own_clock(rospy)
        for controller in self.controllers:
            controller.start()

    @staticmethod
    def _own_clock(rospy: Any) -> bool:
        """With /use_sim_time, rospy subscribes the node to the /clock it publishes itself: every message would come
        back through a rospy thread (deserialised, a callback) to set the node's ROS time, contending for the GIL
        with the simulation thread. The subscription is dropped and the simulation thread sets the ROS time at each
        /clock instant instead (the node's timers, actionlib's status among them, still run on simulated time).
        True when it does so."""
        if rospy.rostime.is_wallclock():
            return False
        from rospy.impl import simtime

        if simtime._clock_sub is not None:
            simtime._clock_sub.unregister()
            simtime._clock_sub = None
        return True

    def _load_controllers(self, rospy: Any, msgs: Any) -> list[Loaded]:
        """The controllers ur5_bringup.launch and the SVH driver load: joint_state_controller, one trajectory
        controller per group (the arm's second one stopped), the arm's velocity group (stopped)."""
        from svhdesc.ros1.controller import TrajectoryController
        from svhdesc.ros1.manager import Loaded
        from svhdesc.ros1.velocity import VelocityGroupController

        sim, info = self.sim, self.sim.info
        loaded = [Loaded(JOINT_STATE_CONTROLLER, CONTROLLER_TYPES[JOINT_STATE_CONTROLLER], STATE_INTERFACE, [], True)]
        for name, kind_name, joints, partial, kind, running in _trajectory_groups(info):
            controller = TrajectoryController(
                name,
                joints,
                sim,
                msgs,
                partial,
                _tolerances(rospy, name, joints, kind),
                self.queue,
                self._collect,
                feedback_period=1.0 / ACTION_MONITOR_RATE[kind],
                state_period=1.0 / float(rospy.get_param(f"{name}/state_publish_rate", STATE_PUBLISH_RATE[kind])),
                running=running,
                reports_velocity=REPORTS_VELOCITY[kind],
                update_period=1.0 / CONTROLLER_UPDATE_RATE[kind],
            )
            self.controllers.append(controller)
            loaded.append(Loaded(name, kind_name, POSITION_INTERFACE, list(joints), running, controller))
        if info.arm_joints:
            velocity = VelocityGroupController(ARM_VELOCITY_CONTROLLER, info.arm_joints, sim, self.queue)
            self._velocity_controllers.append(velocity)
            kind_name = CONTROLLER_TYPES[ARM_VELOCITY_CONTROLLER]
            loaded.append(
                Loaded(ARM_VELOCITY_CONTROLLER, kind_name, VELOCITY_INTERFACE, list(info.arm_joints), False, velocity)
            )
        return loaded + self._forward_controllers(info)

    def _forward_controllers(self, info: Any) -> list[Loaded]:
        """ros_controllers' position groups, loaded stopped, named as the ROS 2 node's forward position controllers
        (neither ROS 1 driver has one): over the arm, then over the hand's channels."""
        from svhdesc.ros1.forward import ForwardController
        from svhdesc.ros1.manager import Loaded

        hand = ros2_hand_forward_controller(info.hand_prefix or "hand", bool(info.arm_joints))
        groups = [(ROS2_FORWARD_CONTROLLER, info.arm_joints), (hand, info.hand_channels)]
        loaded = []
        for name, joints in groups:
            if joints:
                controller = ForwardController(name, joints, self.sim, self.queue)
                loaded.append(Loaded(name, ROS2_FORWARD_TYPE, POSITION_INTERFACE, list(joints), False, controller))
        if info.velocity_joints:  # velocity servos: velocity_controllers' group, running from the start
            velocity = ForwardController(VELOCITY_SERVO_CONTROLLER, info.velocity_joints, self.sim, self.queue)
            velocity.core.running = True
            joints = list(info.velocity_joints)
            loaded.append(
                Loaded(VELOCITY_SERVO_CONTROLLER, VELOCITY_SERVO_TYPE, VELOCITY_INTERFACE, joints, True, velocity)
            )
        return loaded

    def _connect(self, rospy: Any, connector: Sequence[ConnectorJoint], float64: Any) -> list[tuple[str, Any]]:
        """The connector's gains, subscriptions and pose publishers; (joint, pose publisher) in its order."""
        topics = []
        for joint in connector:
            self.sim.actuator(joint.name)  # an unknown joint fails here, before anything runs
            self.sim.set_gains(joint.name, joint.p_gain, joint.d_gain)
            topics.append((joint.name, synchronous_publisher(joint.pose_topic, float64)))
            rospy.Subscriber(joint.control_topic, float64, self._queued(self._on_target, joint.name), queue_size=10)
            rospy.Subscriber(joint.initpose_topic, float64, self._queued(self._on_initpose, joint.name), queue_size=10)
        return topics

    def _queued(self, handler: Any, joint: str) -> Any:
        return lambda msg: self.queue.append((handler, (joint, msg)))

    def _checked(self, joint: str, msg: Any) -> float:
        """The message's value, if finite and within the joint's range (the servo would clamp it)."""
        value = float(msg.data)
        low, high = self.sim.limits(joint)
        if not math.isfinite(value) or not low <= value <= high:
            raise SvhdescError(f"{value} is not finite or outside [{low}, {high}]")
        return value

    def _on_target(self, item: tuple[str, Any]) -> None:
        joint, msg = item
        try:
            self.sim.set_target(joint, self._checked(joint, msg))
        except (SvhdescError, TypeError, ValueError) as exc:
            self._rospy.logwarn(f"connector: target for {joint} ignored: {exc}")

    def _on_initpose(self, item: tuple[str, Any]) -> None:
        joint, msg = item
        try:
            self.sim.set_joint_position(joint, self._checked(joint, msg))
        except (SvhdescError, TypeError, ValueError) as exc:
            self._rospy.logwarn(f"connector: initial pose for {joint} ignored: {exc}")

    def _drain(self, limit: int | None = None) -> None:
        """Work the callbacks queued, at most ``limit`` items (a burst of goals is then spread over many
        control updates, and the physics, /clock and /joint_states go on between them)."""
        drain(self.queue, self._rospy.logerr, limit)

    def _collect(self, batch: list[tuple[Any, Any]]) -> None:
        """What the controllers publish in one control update, for the Outbox."""
        self.outbox.extend(batch)

    def publish_state(self) -> None:
        """/joint_states, the connector's poses, tracked bodies and fingertip wrenches: read here, built
        into messages and published on the Outbox's thread."""
        sim = self.sim
        reading = (
            sim.time,
            sim.joint_state(),
            [sim.body_pose(body) for body, _ in self._tracked],
            [sim.contact_wrench(body) for body, _, _ in self._wrenches],
        )
        self.outbox.add(self._publish_reading, reading)

    def _publish_reading(self, reading: tuple[float, Any, list[Any], list[Any]]) -> None:
        """On the Outbox's thread. Messages are refilled, not rebuilt: a synchronous publish has serialised a
        message when it returns."""
        seconds, state, poses, wrenches = reading
        stamp = self._rospy.Time.from_sec(seconds)
        message = self._joint_state_message
        message.name = list(state.names)
        message.position = state.positions.tolist()
        message.velocity = state.velocities.tolist()
        message.effort = state.efforts.tolist()
        message.header.stamp = stamp
        self._joint_states.publish(message)
        positions = dict(zip(state.names, message.position))
        for (joint, publisher), value in zip(self._pose_topics, self._pose_messages):
            value.data = positions[joint]
            publisher.publish(value)
        for (_, publisher), (position, quaternion) in zip(self._tracked, poses):
            pose = self._PoseStamped()
            pose.header.stamp, pose.header.frame_id = stamp, self._frame
            pose.pose.position.x, pose.pose.position.y, pose.pose.position.z = position.tolist()
            o = pose.pose.orientation
            o.w, o.x, o.y, o.z = quaternion.tolist()
            publisher.publish(pose)
        for (_, frame, publisher), (force, torque) in zip(self._wrenches, wrenches):
            wrench = self._WrenchStamped()
            wrench.header.stamp, wrench.header.frame_id = stamp, frame
            wrench.wrench.force.x, wrench.wrench.force.y, wrench.wrench.force.z = force.tolist()
            wrench.wrench.torque.x, wrench.wrench.torque.y, wrench.wrench.torque.z = torque.tolist()
            publisher.publish(wrench)

    def _publish_clock(self, seconds: float) -> None:
        self._clock_message.clock = self._rospy.Time.from_sec(seconds)
        self._clock.publish(self._clock_message)

    def _periods(self) -> list[float]:
        """Every period something is due on: /clock, /joint_states, each controller's updates and state (the
        feedback comes at its rate on its controller's update grid)."""
        periods = [self._clock_period, self._period]
        for controller in self.controllers:
            periods += [controller.core.update_period, controller.core.state_period]
        return periods

    def spin(self, duration: float = math.inf, realtime: bool = True, viewer: Any = None) -> float:
        """Run until shutdown (or ``duration`` simulated seconds); returns the real-time factor.

        The runtime calls back at every instant something is due (the union of the periods: /clock 100 Hz,
        /joint_states, the controllers' state and feedback); there the controllers update, messages go to
        the Outbox and a bounded slice of the queued work is done. Between two instants the physics runs
        in one chunk with no Python per step."""
        rospy, sim = self._rospy, self.sim
        timestep = sim.timestep
        next_state = next_clock = sim.time
        self._drain()
        periods = self._periods()
        sim.control_steps = max(1, round(max(periods) / timestep))  # updates come at the callbacks

        def between_steps(sim: Any) -> bool:
            nonlocal next_state, next_clock
            now = sim.time
            if due(now, next_clock, timestep):
                if self._drives_ros_time:
                    rospy.rostime._set_rostime(rospy.Time.from_sec(now))
                self.outbox.add(self._publish_clock, now)
                next_clock = next_tick(next_clock, self._clock_period, now)
            for controller in self.controllers:
                controller.update()
            for velocity in self._velocity_controllers:
                velocity.update()
            if due(now, next_state, timestep):
                self.publish_state()
                next_state = next_tick(next_state, self._period, now)
            self.outbox.flush()  # at most every HANDOVER wall seconds (control/outbox.py)
            if viewer is not None:
                viewer.sync()
                if not viewer.running:
                    return False
            if rospy.is_shutdown():
                return False
            self._drain(WORK_PER_UPDATE)  # commands that arrived meanwhile act on the next chunk
            return True

        between_steps(sim)  # t0: the first /clock and state
        factor = sim.run(duration, realtime=realtime, every=periods, callback=between_steps)
        self.outbox.flush(force=True)  # what the last updates collected
        return factor


def default_connector(variant: str) -> Path:
    from svhdesc.model import get

    return get(variant).directory / "config" / "connector.yaml"


def run_node(
    variant: str,
    keyframe: str | None,
    viewer: bool,
    duration: float | None,
    realtime: bool,
    track: Sequence[str],
    rate: float,
    connector: Path | None,
    ros_args: list[str],
    objects: Sequence[Any] = (),
) -> None:
    """``svhdesc sim VARIANT --ros``: serve the simulation to the ROS master in ROS_MASTER_URI."""
    if not rate > 0:
        raise SvhdescError(f"--rate must be positive, got {rate}")
    # rospy leaves sockets to the garbage collector at shutdown: not the user's concern.
    warnings.filterwarnings("ignore", category=ResourceWarning)
    rospy = import_ros()
    from svhdesc.sim.objects import add_objects

    sim = Simulation(variant, keyframe, edit=lambda spec: add_objects(spec, objects))
    for body in track:
        sim.body_pose(body)
    path = connector or default_connector(variant)
    joints = load_connector(path) if path.is_file() or connector is not None else []
    import rosgraph

    if not rosgraph.Master("/svhdesc_sim").is_online():  # rospy would wait for it forever
        raise SvhdescError(f"no ROS master at {rosgraph.get_master_uri()}: start roscore (or use roslaunch)")
    window = None
    if viewer:
        from svhdesc.sim.viewer import Viewer

        window = Viewer(sim.model, sim.data)
    rospy.init_node(NODE_NAME, argv=["svhdesc", *ros_args], disable_signals=False)
    clock_rate = float(rospy.get_param("~clock_rate", 100.0))  # Gazebo's pub_clock_frequency default
    rate = float(rospy.get_param("~rate", rate))
    if not (clock_rate > 0 and rate > 0):
        raise SvhdescError(f"~clock_rate and ~rate must be positive, got {clock_rate}, {rate}")
    node = SimNode(sim, joints, track, rate, clock_rate)
    rospy.loginfo(f"{variant}: simulating ({'real time' if realtime else 'as fast as possible'})")
    try:
        factor = node.spin(math.inf if duration is None else duration, realtime, window)
    finally:
        node.outbox.close()
        if window is not None:
            window.close()
    rospy.loginfo(f"{variant}: {sim.time:.3f} s simulated at {factor:.2f}x real time")
    rospy.signal_shutdown("done")
