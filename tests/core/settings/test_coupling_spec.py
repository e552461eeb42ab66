"""The coupling spec: loaded once, checked strictly, and the only place a ratio lives."""

from __future__ import annotations

import subprocess
import warnings
from pathlib import Path

import numpy as np
import pytest

from svhdesc.core.settings.coupling import CouplingWarning, apply_spec, image, linearise, load_spec
from svhdesc.errors import SvhdescError
from svhdesc.ir import Joint, Link, Robot
from tests.support import REPO

SPEC = REPO / "config" / "coupling.yaml"
GOOD_CHANNELS = """channels:
  - {name: A, range: [0.0, 1.0], effort: 1.0, velocity: 1.0}
  - {name: B, range: [0.0, 1.0], effort: 1.0, velocity: 1.0}
"""


def robot(upper: float = 2.0) -> Robot:
    """A chain base - l0 - l1 - l2 - l3 through the joints h_A, h_B (the channels), h_c and h_d."""
    joints = [
        Joint(f"h_{n}", "revolute", "base" if i == 0 else f"l{i - 1}", f"l{i}", lower=0.0, upper=upper)
        for i, n in enumerate(["A", "B", "c", "d"])
    ]
    links = [Link("base")] + [Link(f"l{i}") for i in range(4)]
    return Robot("toy", tuple(links), tuple(joints), "base")


def write(tmp_path: Path, couplings: str) -> Path:
    path = tmp_path / "spec.yaml"
    path.write_text(GOOD_CHANNELS + "couplings:\n" + couplings)
    return path


def test_project_spec_has_nine_channels_in_driver_order_and_eleven_couplings() -> None:
    spec = load_spec(SPEC)
    assert [c.name for c in spec.channels] == [
        "Thumb_Flexion",
        "Thumb_Opposition",
        "Index_Finger_Distal",
        "Index_Finger_Proximal",
        "Middle_Finger_Distal",
        "Middle_Finger_Proximal",
        "Ring_Finger",
        "Pinky",
        "Finger_Spread",
    ]
    assert len(spec.couplings) == 11


def test_ratio_appears_once_in_the_sources() -> None:
    tracked = subprocess.run(
        ["git", "ls-files", "xacro", "config", "svhdesc", "tools"],
        cwd=REPO,
        capture_output=True,
        text=True,
        check=True,
    ).stdout.split()
    hits = [f for f in tracked if "1.0454" in (REPO / f).read_text(errors="ignore")]
    assert hits == ["config/coupling.yaml"]
    assert (REPO / "config/coupling.yaml").read_text().count("1.0454") == 1


@pytest.mark.parametrize(
    ("couplings", "message"),
    [
        ("  - {joint: x, follows: A, poly: [0, 1]}\n", "unknown joint h_x"),
        (
            "  - {joint: c, follows: A, poly: [0, 1]}\n  - {joint: c, follows: A, poly: [0, 1]}\n",
            "c duplicated",
        ),
        (
            "  - {joint: c, follows: A, poly: [0, 1]}\n  - {joint: c, follows: B, poly: [0, 1]}\n",
            "driven twice",
        ),
        ("  - {joint: B, follows: A, poly: [0, 1]}\n", "B is a channel"),
        ("  - {joint: c, follows: A, poly: [0, 1]}\n  - {joint: d, follows: c, poly: [0, 1]}\n", "a chain"),
        ("  - {joint: c, follows: d, poly: [0, 1]}\n  - {joint: d, follows: c, poly: [0, 1]}\n", "a cycle"),
        ("  - {joint: c, follows: A, poly: [0, 3]}\n", "leaves its limit"),
        ("  - {joint: c, follows: Z, poly: [0, 1]}\n", "unknown channel Z"),
        ("  - {joint: c, follows: A, poly: [0, 1, 0, 0, 0, 1]}\n", "6 terms"),
    ],
)
def test_bad_spec_is_an_error_naming_the_joint(tmp_path: Path, couplings: str, message: str) -> None:
    with pytest.raises(SvhdescError, match=message) as info:
        apply_spec(robot(), load_spec(write(tmp_path, couplings)), "h")
    assert "spec.yaml:" in str(info.value)  # file:line of the culprit


def test_limit_can_be_widened_with_a_warning(tmp_path: Path) -> None:
    spec = load_spec(write(tmp_path, "  - {joint: c, follows: A, poly: [0, 3]}\n"))
    with pytest.warns(CouplingWarning, match="limit widened"):
        result = apply_spec(robot(), spec, "h", widen_limits=True)
    assert result.joint("h_c").upper == pytest.approx(3.0)


def test_higher_order_term_is_linearised_by_least_squares_with_a_warning(tmp_path: Path) -> None:
    spec = load_spec(write(tmp_path, "  - {joint: c, follows: A, poly: [0.1, 0.5, 0.3]}\n"))
    with pytest.warns(CouplingWarning, match="least-squares"):
        result = apply_spec(robot(), spec, "h")
    assert result.joint("h_c").mimic.coeffs == (0.1, 0.5, 0.3)
    offset, multiplier = linearise((0.1, 0.5, 0.3), 0.0, 1.0)
    q = np.linspace(0, 1, 201)
    exact = np.polyfit(q, 0.1 + 0.5 * q + 0.3 * q**2, 1)
    assert (multiplier, offset) == pytest.approx(tuple(exact), abs=1e-12)
    assert multiplier != pytest.approx(0.5)  # really fitted, not the linear term copied


def test_linear_coupling_needs_no_warning(tmp_path: Path) -> None:
    spec = load_spec(write(tmp_path, "  - {joint: c, follows: A, poly: [0, 1.5]}\n"))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        apply_spec(robot(), spec, "h")


def test_image_finds_interior_extrema() -> None:
    low, high = image((0.0, 1.0, -1.0), 0.0, 1.0)  # q - q^2 peaks at 0.25 inside the range
    assert (low, high) == pytest.approx((0.0, 0.25))


def test_mimic_order_follows_urdfdom_name_sorting(tmp_path: Path) -> None:
    # urdfdom (pinocchio) visits sibling joints sorted by name: a follower in a sibling subtree whose
    # joint name sorts first is reached before its channel, which pinocchio's mimic=True rejects.
    from svhdesc.compiler.stages.coupled import mimic_order_problems, urdfdom_joint_order

    links = tuple(Link(n) for n in ("base", "x", "y", "z"))

    def toy(first: str) -> Robot:
        joints = (
            Joint(f"h_{first}", "fixed", "base", "x"),
            Joint("h_c", "revolute", "x", "y", upper=2.0),  # follows B
            Joint("h_B", "revolute", "base", "z", upper=2.0),
            Joint("h_A", "revolute", "z", "l0", upper=2.0),
        )
        return Robot("toy", (*links, Link("l0")), joints, "base")

    spec = write(tmp_path, "  - {joint: c, follows: B, poly: [0.0, 0.5]}\n")
    late = apply_spec(toy("f1"), load_spec(spec), "h")  # "h_B" < "h_f1": the channel comes first
    assert urdfdom_joint_order(late) == ["h_B", "h_A", "h_f1", "h_c"]
    assert mimic_order_problems(late) == []
    early = apply_spec(toy("A0"), load_spec(spec), "h")  # "h_A0" < "h_B": the follower comes first
    assert mimic_order_problems(early) == ["h_c comes before h_B in urdfdom's name-sorted traversal"]
