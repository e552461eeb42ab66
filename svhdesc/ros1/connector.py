"""The thesis' connector file (sec. 4.2.3): one entry per actuated joint.

joints:
- name: right_hand_Pinky            # a joint of the MJCF
  control_topic: /mujoco/right_hand_Pinky/control    # std_msgs/Float64 targets in
  pose_topic: /mujoco/right_hand_Pinky/pose          # std_msgs/Float64 positions out
  initpose_topic: /mujoco/right_hand_Pinky/initpose  # std_msgs/Float64: reset the joint
  p_gain: 10.0                      # ctrl = -p_gain (q - q_ref) - d_gain q_dot  (eq. 4.2)
  d_gain: 0.05
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import yaml

from svhdesc.errors import SvhdescError

FIELDS = ("name", "control_topic", "pose_topic", "initpose_topic", "p_gain", "d_gain")


@dataclass(frozen=True)
class ConnectorJoint:
    name: str
    control_topic: str
    pose_topic: str
    initpose_topic: str
    p_gain: float
    d_gain: float


def load_connector(path: Path) -> list[ConnectorJoint]:
    """Read and check a connector file; errors name the file and the entry."""
    try:
        document = yaml.safe_load(path.read_text())
    except OSError as exc:
        raise SvhdescError(f"{path}: {exc.strerror}") from None
    except yaml.YAMLError as exc:
        raise SvhdescError(f"{path}: not YAML: {exc}") from None
    entries = document.get("joints") if isinstance(document, dict) else None
    if not isinstance(entries, list):
        raise SvhdescError(f"{path}: expected a 'joints:' list")
    joints = []
    for i, entry in enumerate(entries):
        where = f"{path}: joints[{i}]"
        if not isinstance(entry, dict):
            raise SvhdescError(f"{where}: expected a mapping with {', '.join(FIELDS)}")
        missing = [f for f in FIELDS if f not in entry]
        unknown = sorted(set(entry) - set(FIELDS))
        if missing or unknown:
            raise SvhdescError(f"{where}: missing {missing or 'nothing'}, unknown {unknown or 'nothing'}")
        for key in ("p_gain", "d_gain"):
            value = entry[key]
            if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value) or value < 0:
                raise SvhdescError(f"{where}: {key} must be a finite number >= 0, got {value!r}")
        for key in ("name", "control_topic", "pose_topic", "initpose_topic"):
            if not isinstance(entry[key], str) or not entry[key]:
                raise SvhdescError(f"{where}: {key} must be a non-empty string")
        joints.append(ConnectorJoint(**{k: entry[k] for k in FIELDS}))
    names = [j.name for j in joints]
    if len(set(names)) != len(names):
        raise SvhdescError(f"{path}: a joint is listed twice")
    return joints
