"""The ROS 2 (Jazzy) adapter: ``svhdesc sim VARIANT --ros2``, an rclpy node with the interfaces of SCHUNK's ROS 2
SVH driver and ur_robot_driver's ROS 2 driver over the shared controller core (svhdesc.control); see docs/ros2.md.

rclpy is imported only where the node starts (svhdesc.ros2.system.import_rclpy): it lives in .venv-ros2."""
