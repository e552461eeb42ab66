"""The ROS 2 node (``svhdesc sim VARIANT --ros2``): the simulation behind the ROS 2 drivers' interfaces.

What it serves (names from the variant's ``ros2/config/ros2_controllers.yaml``, written from svhdesc.model's ROS 2
names: SCHUNK's schunk_svh_ros_driver and ur_robot_driver's ROS 2 configs, see docs/ros2.md):
  /clock                                              rosgraph_msgs/msg/Clock, simulated time (use_sim_time)
  joint_states                                        sensor_msgs/msg/JointState, every joint (joint_state_broadcaster)
  <controller>/follow_joint_trajectory                control_msgs/action/FollowJointTrajectory (Jazzy JTC)
  <controller>/controller_state                       control_msgs/msg/JointTrajectoryControllerState
  controller_manager/list_controllers, switch_controller   controller_manager_msgs/srv
with <controller> ``right_hand`` / ``left_hand`` and, with an arm, ``scaled_joint_trajectory_controller``.

One control update per controller-manager period (``update_rate``, 125 Hz): the simulation steps the physics for a
period, then this node publishes /clock, updates each controller (tolerances, feedback, controller_state),
publishes joint_states, records, and runs the work rclpy's callbacks queued (at most
svhdesc.control.work.WORK_PER_UPDATE items per update, the rest at the next ones). rclpy's executor spins in its own
thread and never touches the simulation.
"""

from __future__ import annotations

import math
import sys
import threading
from collections import deque
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from svhdesc.control.goals import Tolerances
from svhdesc.control.manager import SWITCH_JAZZY, Loaded
from svhdesc.control.outbox import Outbox
from svhdesc.control.work import drain
from svhdesc.errors import SvhdescError
from svhdesc.model import (
    JTC_DEFAULTS,
    NODE_NAME,
    REPORTS_VELOCITY,
    ROS2_FORWARD_TYPE,
    ROS2_JOINT_STATE_BROADCASTER,
    ROS2_JTC_TYPE,
    VELOCITY_SERVO_TYPE,
    ros2_joint_name,
)
from svhdesc.ros2.graph import (
    TF_RATE,
    StatePublisher,
    clock_template,
    controller_parameters,
    description,
    joint_state_template,
    node_with,
    system_joints,
    urdf_xacro,
)
from svhdesc.ros2.hardware import HardwareState
from svhdesc.ros2.system import import_rclpy
from svhdesc.sim import Simulation

TRACKING_FRAME = "world"  # MuJoCo's world frame, the URDF's root link
_NO_VALUES = np.zeros(0)


def controllers_file(variant: str) -> Path:
    from svhdesc.model import get

    return get(variant).directory / "ros2" / "config" / "ros2_controllers.yaml"


def read_controllers(path: Path) -> tuple[float, dict[str, str], dict[str, dict]]:
    """(update_rate, {controller: type}, {controller: its ros__parameters}) of a ros2_controllers.yaml."""
    if not path.is_file():
        raise SvhdescError(f"{path} is missing: rebuild the variant (svhdesc build) to write its ROS 2 files")
    try:
        data = yaml.safe_load(path.read_text())
        manager = data["controller_manager"]["ros__parameters"]
        rate = float(manager["update_rate"])
        types = {name: value["type"] for name, value in manager.items() if isinstance(value, dict)}
        parameters = {name: data.get(name, {}).get("ros__parameters", {}) for name in types}
    except (yaml.YAMLError, KeyError, TypeError, ValueError, AttributeError) as exc:
        raise SvhdescError(f"{path}: not a ros2_controllers file ({type(exc).__name__}: {exc})") from None
    if not 0 < rate < math.inf:
        raise SvhdescError(f"{path}: update_rate must be positive, got {rate}")
    return rate, types, parameters


def tolerances(parameters: dict, joints: Sequence[str], to_ros: dict[str, str]) -> Tolerances:
    """JTC's ``constraints`` (ROS 2 names in the yaml) over the simulation's joint names; JTC's defaults where
    the yaml declares none."""
    constraints = parameters.get("constraints", {})

    def joint(name: str, key: str) -> float:
        return float(constraints.get(to_ros[name], {}).get(key, JTC_DEFAULTS[key]))

    return Tolerances(
        path={j: joint(j, "trajectory") for j in joints},
        goal={j: joint(j, "goal") for j in joints},
        stopped_velocity=float(
            constraints.get("stopped_velocity_tolerance", JTC_DEFAULTS["stopped_velocity_tolerance"])
        ),
        goal_time=float(constraints.get("goal_time", JTC_DEFAULTS["goal_time"])),
    )


class SimNode:
    def __init__(self, sim: Simulation, controllers: Path, recorder: Any = None, track: Sequence[str] = ()) -> None:
        """``track``: bodies of the simulation whose poses are published on ``tracked/<body>`` every update."""
        rclpy = import_rclpy()
        from builtin_interfaces.msg import Time
        from geometry_msgs.msg import PoseStamped
        from rclpy.clock_type import ClockType
        from rclpy.executors import SingleThreadedExecutor
        from rclpy.time import Time as RosTime
        from rosgraph_msgs.msg import Clock
        from sensor_msgs.msg import JointState

        from svhdesc.ros2.controller import TrajectoryController, stamp
        from svhdesc.ros2.forward import ForwardController
        from svhdesc.ros2.manager import ControllerManager

        self._rclpy, self.sim, self.recorder = rclpy, sim, recorder
        self.queue: deque = deque()
        self._Time, self._Clock, self._JointState, self._stamp = Time, Clock, JointState, stamp
        rate, types, parameters = read_controllers(controllers)
        self.period = 1.0 / rate
        # The node publishes /clock itself: a TimeSource's /clock subscription (use_sim_time) would take every
        # message back through rclpy's executor, a Python callback per update contending for the GIL with the
        # simulation thread (the as-fast rate 1.2-1.6x lower). node_with drops it and publish() sets each node's ROS
        # time instead; use_sim_time stays true, so the nodes' clocks (goal stamps, timers) are simulated time.
        self.node = node_with(rclpy, NODE_NAME, {})
        self.nodes = self._graph(controllers, rate, types, parameters)
        # Clocks set each update: the simulation's and the trajectory controllers' (their action servers stamp goals);
        # the other nodes stamp nothing with their own clock (every message carries the simulation's stamp).
        timed = [self.node, *(self.nodes[name] for name, kind in types.items() if kind == ROS2_JTC_TYPE)]
        self._ros_clocks = [n.get_clock() for n in timed]
        self._RosTime, self._ros_time = RosTime, ClockType.ROS_TIME
        self.executor = SingleThreadedExecutor()
        for node in (self.node, *self.nodes.values()):
            self.executor.add_node(node)
        self._clock = self.node.create_publisher(Clock, "/clock", 10)
        broadcaster = self.nodes[ROS2_JOINT_STATE_BROADCASTER]
        self._joint_states = broadcaster.create_publisher(JointState, "joint_states", 10)
        # joint_state_broadcaster's order: the ros2_control system's joints (the generated ros2_control xacro)
        ros_names = [ros2_joint_name(j) for j in sim.info.joints]
        order = [ros_names.index(j) for j in system_joints(self._xacro) if j in ros_names]
        order += [k for k in range(len(ros_names)) if k not in order]
        self._order = np.array(order, dtype=int)
        self._names = [ros_names[k] for k in order]
        self._joint_state_bytes = joint_state_template(self._names)
        self._clock_bytes = clock_template()
        self._hardware = HardwareState(broadcaster, self.nodes.get("svh"), sim, self._names, self._xacro)
        self._tf = StatePublisher(self.nodes["robot_state_publisher"], self._urdf, self._names)
        for body in track:
            sim.body_pose(body)  # an unknown body fails here, before anything is served
        self._PoseStamped = PoseStamped
        self._tracked = [(body, self.node.create_publisher(PoseStamped, f"tracked/{body}", 10)) for body in track]
        self.controllers: list[TrajectoryController] = []
        self.forward_controllers: list[ForwardController] = []
        self.outbox = Outbox()  # messages are built and published on its thread (control/outbox.py)
        loaded, interfaces = self._load(controllers, types, parameters)
        self.manager = ControllerManager(self.nodes["controller_manager"], loaded, interfaces, self.queue, SWITCH_JAZZY)
        self._spinner = threading.Thread(target=self._spin, name="svhdesc-rclpy", daemon=True)
        self._stopped = threading.Event()

    def _graph(
        self, controllers: Path, rate: float, types: dict[str, str], parameters: dict[str, dict]
    ) -> dict[str, Any]:
        """The nodes of a ros2_control system beside the simulation's: controller_manager, one per controller,
        robot_state_publisher, and (with a hand) SCHUNK's hardware interface's ``svh``."""
        rclpy = self._rclpy
        self._xacro = urdf_xacro(controllers)
        self._urdf = description(self._xacro, controllers)
        manager = {"update_rate": int(rate) if float(rate).is_integer() else rate}
        manager.update({f"{name}.type": kind for name, kind in types.items()})
        nodes = {"controller_manager": node_with(rclpy, "controller_manager", manager)}
        for name, kind in types.items():
            nodes[name] = node_with(rclpy, name, controller_parameters(kind, parameters[name], ROS2_JTC_TYPE))
        nodes["robot_state_publisher"] = node_with(
            rclpy, "robot_state_publisher", {"robot_description": self._urdf, "publish_frequency": TF_RATE}
        )
        if self.sim.info.hand_channels:
            nodes["svh"] = node_with(rclpy, "svh", {})
        return nodes

    def _load(
        self, path: Path, types: dict[str, str], parameters: dict[str, dict]
    ) -> tuple[list[Loaded], dict[str, tuple[list[str], list[str]]]]:
        """The controllers of the yaml: joint_state_broadcaster (always active) and each trajectory controller."""
        from svhdesc.ros2.controller import TrajectoryController

        sim = self.sim
        to_ros = {j: ros2_joint_name(j) for j in sim.info.actuators}
        to_sim = {ros: j for j, ros in to_ros.items()}
        loaded = []
        interfaces: dict[str, tuple[list[str], list[str]]] = {}
        for name, kind in types.items():
            if name == ROS2_JOINT_STATE_BROADCASTER:
                loaded.append(Loaded(name, kind, "", [], True))
                continue
            params = parameters[name]
            unknown = [j for j in params.get("joints", []) if j not in to_sim]
            if unknown or not params.get("joints"):
                raise SvhdescError(f"{path}: {name} names joints {unknown} that {sim.variant} does not actuate")
            joints = [to_sim[j] for j in params["joints"]]
            commands = [f"{to_ros[j]}/position" for j in joints]
            if kind in (ROS2_FORWARD_TYPE, VELOCITY_SERVO_TYPE):
                loaded.append(self._forward(name, kind, joints, to_ros))
                interfaces[name] = (loaded[-1].resources, [])  # forward_command_controller claims no state interface
                continue
            if kind != ROS2_JTC_TYPE:
                raise SvhdescError(
                    f"{path}: {name} is a {kind}; the node runs {ROS2_JTC_TYPE}, {ROS2_FORWARD_TYPE} and "
                    f"{VELOCITY_SERVO_TYPE}"
                )
            hand = all(j in sim.info.hand_channels for j in joints)
            controller = TrajectoryController(
                self.nodes[name],
                name,
                joints,
                to_ros,
                sim,
                bool(params.get("allow_partial_joints_goal", False)),
                tolerances(params, joints, to_ros),
                self.queue,
                self.executor.wake,
                feedback_period=1.0 / float(params.get("action_monitor_rate", 20.0)),
                state_period=self.period,  # Jazzy's JTC publishes its state every update
                reports_velocity=REPORTS_VELOCITY["hand" if hand else "arm"],
            )
            controller.recorder, controller.outbox = self._record, self.outbox
            self.controllers.append(controller)
            loaded.append(Loaded(name, kind, "position", commands, True, controller))
            interfaces[name] = (
                commands,
                [f"{to_ros[j]}/{i}" for j in joints for i in params.get("state_interfaces", ["position"])],
            )
        return loaded, interfaces

    def _forward(self, name: str, kind: str, joints: list[str], to_ros: dict[str, str]) -> Loaded:
        """A forward command group: the position group loaded inactive, as ur_robot_driver's launch loads it; the
        velocity servos' group active (the launch spawns it so: nothing else drives those joints)."""
        from svhdesc.ros2.forward import ForwardController

        active = kind == VELOCITY_SERVO_TYPE
        interface = "velocity" if active else "position"
        forward = ForwardController(self.nodes[name], name, joints, self.sim, self.queue)
        forward.core.running = active
        forward.on_failure = lambda failed: self.manager.core.fail(failed)
        self.forward_controllers.append(forward)
        return Loaded(name, kind, interface, [f"{to_ros[j]}/{interface}" for j in joints], active, forward)

    def _spin(self) -> None:
        try:
            self.executor.spin()
        except Exception:  # noqa: BLE001 - rclpy raises on shutdown (ExternalShutdownException and kin)
            pass

    def _record(self, topic: str, message: Any, at: float) -> None:
        if self.recorder is not None:
            self.recorder.write(topic, message, at)

    def _drain(self) -> None:
        """At most WORK_PER_UPDATE queued callbacks per control update: a burst of goals is spread over updates,
        and the physics, /clock and joint_states go on between them."""
        drain(self.queue, self.node.get_logger().error)

    def publish(self) -> None:
        """/clock and joint_states at the simulation's time (and into the recording): the state is read here,
        the messages built and published on the Outbox's thread."""
        at = self.sim.time
        now = self._RosTime(nanoseconds=round(at * 1e9), clock_type=self._ros_time)
        for clock in self._ros_clocks:
            clock.set_ros_time_override(now)
        poses = [self.sim.body_pose(body) for body, _ in self._tracked]
        self.outbox.add(self._publish_reading, (at, self.sim.joint_state(), poses, self._hardware.read()))

    def _publish_reading(self, reading: tuple[float, Any, list[Any]]) -> None:
        at, state, poses, hardware = reading
        stamp = self._stamp(self._Time, at)
        self._clock.publish(self._clock_bytes.payload(_NO_VALUES, stamp.sec, stamp.nanosec))
        if self.recorder is not None:
            self._record(self._clock.topic_name, self._Clock(clock=stamp), at)
        order = self._order
        positions, velocities, efforts = state.positions[order], state.velocities[order], state.efforts[order]
        values = np.concatenate([positions, velocities, efforts])
        self._joint_states.publish(self._joint_state_bytes.payload(values, stamp.sec, stamp.nanosec))
        if self.recorder is not None:
            message = self._JointState(
                name=self._names, position=positions.tolist(), velocity=velocities.tolist(), effort=efforts.tolist()
            )
            message.header.stamp = stamp
            self._record(self._joint_states.topic_name, message, at)
        self._hardware.publish(stamp, positions, velocities, efforts, hardware)
        self._tf.publish(stamp, at, positions)
        for (_, publisher), (position, quaternion) in zip(self._tracked, poses):
            pose = self._PoseStamped()
            pose.header.stamp, pose.header.frame_id = stamp, TRACKING_FRAME
            p, o = pose.pose.position, pose.pose.orientation
            p.x, p.y, p.z = position.tolist()
            o.w, o.x, o.y, o.z = quaternion.tolist()  # MuJoCo's quaternions are (w, x, y, z)
            publisher.publish(pose)

    def update(self, _: Any = None) -> bool:
        """One control update (after a period of physics): False once ROS 2 shuts down (SIGINT, SIGTERM)."""
        if not self._rclpy.ok() or self._stopped.is_set():
            return False
        try:
            for controller in self.controllers:
                controller.update()
            self._hardware.settle()
            self.publish()
            self._drain()
            self.outbox.flush()  # at most every HANDOVER wall seconds
        except Exception:
            if self._rclpy.ok():
                raise
            return False  # shut down by a signal between the check above and a publication
        return self._rclpy.ok()

    def spin(self, duration: float = math.inf, realtime: bool = True, viewer: Any = None) -> float:
        """Run until shutdown (or ``duration`` simulated seconds); returns the real-time factor."""
        self.publish()
        self._spinner.start()
        self._drain()

        def between_updates(sim: Simulation) -> bool:
            if viewer is not None:
                viewer.sync()
                if not viewer.running:
                    return False
            return self.update()

        # The runtime steps the physics one control period at a time, keeping to the wall clock when asked; the
        # trajectories are sampled once per period, as ros2_control updates its controllers at update_rate.
        self.sim.control_steps = max(1, round(self.period / self.sim.timestep))
        factor = self.sim.run(duration, realtime=realtime, every=self.period, callback=between_updates)
        self.outbox.flush(force=True)  # what the last updates collected
        return factor

    def stop(self) -> None:
        """End ``spin`` at the next control update (any thread)."""
        self._stopped.set()

    def close(self, shutdown: bool = True) -> None:
        """Stop publishing, the executor and the node; ``shutdown`` rclpy too (False: the caller's rclpy runs on)."""
        self.outbox.close()
        self.executor.shutdown(timeout_sec=2.0)
        for node in (*self.nodes.values(), self.node):
            node.destroy_node()
        if shutdown:
            self._rclpy.try_shutdown()
        self._spinner.join(2.0)


def serve(
    sim: Simulation,
    *,
    track: Sequence[str] = (),
    duration: float = math.inf,
    realtime: bool = True,
    ros_args: Sequence[str] = (),
    record: Path | None = None,
    viewer: bool = False,
    on_start: Callable[[SimNode], Any] | None = None,
) -> float:
    """Serve ``sim`` (a Simulation the caller built, its scene edited as it likes) over ROS 2 with the interfaces of
    ``svhdesc sim --ros2`` plus a PoseStamped on ``tracked/<body>`` for each body of ``track``, until ``duration``
    simulated seconds have passed, SIGINT or SIGTERM arrives, or ``SimNode.stop()`` is called; returns the real-time
    factor. Runs on the calling thread (call it from the main thread: rclpy installs its signal handlers there).
    rclpy is initialised (with ``ros_args`` as remappings) unless the caller already did; then it is left running.
    ``on_start(node)`` runs once the node serves (e.g. to start a client thread)."""
    rclpy = import_rclpy()
    path = controllers_file(sim.variant)
    read_controllers(path)  # a bad file fails before anything starts
    owned = not rclpy.ok()
    recorder = None
    if record is not None:
        from svhdesc.ros2.record import Recorder

        recorder = Recorder(record)
    if owned:
        remaps = [a for arg in ros_args for a in ("-r", arg)]
        rclpy.init(args=["svhdesc", *(["--ros-args", *remaps] if remaps else [])])
    window = None
    node = None
    factor = 0.0
    try:
        node = SimNode(sim, path, recorder, track)
        if viewer:
            from svhdesc.sim.viewer import Viewer

            window = Viewer(sim.model, sim.data)
        logger = node.node.get_logger()
        names = ", ".join(c.name for c in node.controllers)
        pace = "real time" if realtime else "as fast"
        logger.info(f"{sim.variant}: serving {names} at {1 / node.period:g} Hz ({pace})")
        if on_start is not None:
            on_start(node)
        factor = node.spin(duration, realtime, window)
        summary = f"{sim.variant}: {sim.time:.3f} s simulated at {factor:.2f}x real time"
        if rclpy.ok():
            logger.info(summary)
        else:  # stopped by a signal: rosout is gone
            print(f"[INFO] [{NODE_NAME}]: {summary}", file=sys.stderr)
    finally:
        _close(rclpy, node, recorder, window, owned)
    return factor


def _close(rclpy: Any, node: SimNode | None, recorder: Any, window: Any, owned: bool) -> None:
    """Every message sent (and recorded) before the recording closes; rclpy shut down if ``serve`` started it."""
    if node is not None:
        node.outbox.close()
    if recorder is not None:
        recorder.close()
    if window is not None:
        window.close()
    if node is not None:
        node.close(shutdown=owned)
    if owned:
        rclpy.try_shutdown()


def run_node(
    variant: str,
    keyframe: str | None,
    viewer: bool,
    duration: float | None,
    realtime: bool,
    ros_args: list[str],
    record: Path | None = None,
    objects: Sequence[Any] = (),
    track: Sequence[str] = (),
) -> None:
    """``svhdesc sim VARIANT --ros2``: serve the simulation over ROS 2 (DDS discovery as ROS_* variables say)."""
    import_rclpy()
    from svhdesc.sim.objects import add_objects

    read_controllers(controllers_file(variant))  # a bad file fails before the scene compiles
    sim = Simulation(variant, keyframe, edit=lambda spec: add_objects(spec, objects))
    for body in track:
        sim.body_pose(body)  # unknown bodies fail before anything starts
    serve(
        sim,
        track=track,
        duration=math.inf if duration is None else duration,
        realtime=realtime,
        ros_args=ros_args,
        record=record,
        viewer=viewer,
    )
