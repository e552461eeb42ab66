"""Transport-free controller semantics shared by the ROS 1 and ROS 2 adapters.

ros_controllers' joint_trajectory_controller and ros_control's controller_manager on plain Python
values: goals, feedback, results and controller states are dataclasses; no rospy, no rclpy. An adapter
turns messages into these values, calls the core on the simulation thread and turns what the core
reports back into messages (see notes in svhdesc/ros1/controller.py).
"""
