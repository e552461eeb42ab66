"""Moved to ``svhdesc.frames`` (every layer uses it); kept for existing imports."""

from ..frames import matrix_pose, pose_matrix, quat_wxyz, rpy_matrix

__all__ = ["matrix_pose", "pose_matrix", "quat_wxyz", "rpy_matrix"]
