"""control_msgs and controller_manager_msgs, built at install time by rosidl from svhdesc/ros2/interfaces/.

Runs in .venv-ros2 (`.venv-ros2/bin/python -m pytest -n 0 tests/ros2`); skips where rclpy is missing.

Checked against the committed definition files themselves: every field the .action/.srv/.msg names is a field of the
generated class, and a goal survives rclpy's CDR round trip. Seeded fault: deleting `string error_string` from
the committed FollowJointTrajectory.action (definition and build then disagree) fails
test_generated_fields_match_the_definitions.
"""

from __future__ import annotations

import importlib
import re
from pathlib import Path

import pytest

pytest.importorskip("rclpy")
control_msgs = pytest.importorskip("control_msgs.action")
pytestmark = pytest.mark.ros

INTERFACES = Path(__file__).resolve().parents[2] / "svhdesc" / "ros2" / "interfaces"
FIELD = re.compile(r"^\s*([A-Za-z_][\w/]*(?:\[\])?)\s+([a-z_]\w*)\s*(?:#.*)?$")


def _sections(path: Path) -> list[set[str]]:
    """The field names of each section (request/response, goal/result/feedback) of a definition file."""
    sections: list[set[str]] = [set()]
    for line in path.read_text().splitlines():
        if line.strip() == "---":
            sections.append(set())
        elif (m := FIELD.match(line)) and "=" not in line:
            sections[-1].add(m.group(2))
    return sections


PARTS = {".msg": [""], ".srv": ["Request", "Response"], ".action": ["Goal", "Result", "Feedback"]}
DEFINITIONS = sorted(p for p in INTERFACES.rglob("*") if p.suffix in PARTS)


@pytest.mark.parametrize("path", DEFINITIONS, ids=lambda p: f"{p.parent.parent.name}/{p.name}")
def test_generated_fields_match_the_definitions(path: Path) -> None:
    module = importlib.import_module(f"{path.parent.parent.name}.{path.parent.name}")
    top = getattr(module, path.stem)
    for part, fields in zip(PARTS[path.suffix], _sections(path), strict=True):
        cls = getattr(top, part) if part else top
        assert set(cls.get_fields_and_field_types()) == fields, (path.name, part)


def test_a_goal_survives_cdr_round_trip() -> None:
    from builtin_interfaces.msg import Duration
    from control_msgs.msg import JointTolerance
    from rclpy.serialization import deserialize_message, serialize_message
    from trajectory_msgs.msg import JointTrajectoryPoint

    goal = control_msgs.FollowJointTrajectory.Goal()
    goal.trajectory.joint_names = ["right_hand_Thumb_Flexion"]
    goal.trajectory.points = [JointTrajectoryPoint(positions=[0.3], time_from_start=Duration(sec=1))]
    goal.goal_tolerance = [JointTolerance(name="right_hand_Thumb_Flexion", position=0.01)]
    back = deserialize_message(serialize_message(goal), control_msgs.FollowJointTrajectory.Goal)
    assert back == goal
    assert control_msgs.FollowJointTrajectory.Result.PATH_TOLERANCE_VIOLATED == -4
