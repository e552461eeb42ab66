"""``svhdesc mjlab train|play``'s bad input, in .venv (no mjlab): each one error line, exit 2, nothing written --
an unknown task, an unknown variant, a variant without a hand (a built folder whose manifest names none), a hand
without the arm the lift's pose names; and with all of them right, mjlab missing, naming the extra. The checks run
in this order, so that each case here meets its own (seeded fault: a check removed lets its case through to the
next one's message, and the test fails)."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import mujoco
import pytest

from tests.support import REPO, fails_cleanly


def bare_variant(folder: Path) -> Path:
    """A built variant's folder without a hand: one hinge and its servo, model and batch model, no manifest."""
    spec = mujoco.MjSpec()
    body = spec.worldbody.add_body(name="link")
    body.add_joint(name="hinge", type=mujoco.mjtJoint.mjJNT_HINGE, range=(-1.0, 1.0))
    body.add_geom(type=mujoco.mjtGeom.mjGEOM_SPHERE, size=(0.05, 0.0, 0.0), mass=1.0)
    spec.add_actuator(name="hinge", target="hinge", trntype=mujoco.mjtTrn.mjTRN_JOINT)
    spec.compile()
    folder.mkdir()
    for name in (f"{folder.name}.xml", f"{folder.name}_batch.xml"):
        (folder / name).write_text(spec.to_xml())
    return folder


@pytest.mark.parametrize(
    ("args", "match"),
    [
        (("mjlab", "train", "Svh-Reach"), "unknown task 'Svh-Reach'"),
        (("mjlab", "play", "Svh-Rotate", "--variant", "svh_middle"), "unknown variant 'svh_middle'"),
        (("mjlab", "train", "Ur5-Svh-Lift", "--variant", "svh_left"), "Ur5-Svh-Lift needs a hand and arm"),
    ],
)
def test_bad_input_is_one_error_line(args: tuple[str, ...], match: str) -> None:
    fails_cleanly(None, *args, match=match)
    assert not (REPO / "logs").exists()  # where mjlab's train would write


def test_a_variant_without_a_hand(tmp_path: Path) -> None:
    folder = bare_variant(tmp_path / "bare")
    fails_cleanly(tmp_path, "mjlab", "train", "Svh-Rotate", "--variant", str(folder), match="bare has no hand")


@pytest.mark.skipif(importlib.util.find_spec("mjlab") is not None, reason="mjlab is installed here")
def test_mjlab_missing_names_the_extra() -> None:
    fails_cleanly(None, "mjlab", "train", "Svh-Rotate", "--variant", "svh_right", match="pip install 'svhdesc[mjlab]'")
