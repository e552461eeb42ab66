"""What the settings say of one model's simulation (`svhdesc validate PATH`'s full tier): a URDF's rest pose, an
MJCF's keyframe by name, and joints' quirks (their rated force, the miss range_of_motion allows them, checks they are
left out of). Read and checked in svhdesc.validate.settings; used where the model is compiled."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field


@dataclass(frozen=True)
class JointSettings:
    """One joint's quirks: its rated force over the source's, the miss range_of_motion allows it, checks it is left
    out of (with why)."""

    effort: float | None = None  # N m or N: a URDF's <limit effort> (and its servo's force), an MJCF's force bound
    tolerance: float | None = None  # rad or m an end of its range may be missed by (range_of_motion; else 1 %)
    ignore: Mapping[str, str] = field(default_factory=dict)  # gravity_hold or range_of_motion -> why


@dataclass(frozen=True)
class Quirks:
    """What the settings say of one model's simulation: a URDF's rest pose, an MJCF's keyframe, joints' quirks."""

    pose: Mapping[str, float] = field(default_factory=dict)
    keyframe: str | None = None
    joints: Mapping[str, JointSettings] = field(default_factory=dict)
