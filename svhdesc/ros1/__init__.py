"""The ROS 1 node: the simulation behind the SVH driver's and ur_robot_driver's interfaces.

Nothing here imports rospy at import time; ``system.import_ros`` finds Debian's ROS packages.
"""
