"""svhdesc compare: eq. 5.1, the four engines on the contact experiment, and a missing engine."""

from __future__ import annotations

import csv
import json
import subprocess
import sys
from functools import cache

import numpy as np
import pytest

from svhdesc.compare import experiment
from svhdesc.compare.runner import STATUS_MISSING, STATUS_OK, Result, run_grid

VARIANT = "ur5_svh_right"
SHORT = 1.0  # s: ramp 0.2 s, then the fingertip presses; keeps each engine to a few seconds


def test_mad_matches_hand_computed_series() -> None:
    # Window 3 by hand: x = 0 3 6 3 -> running means 3, 4 at samples 3, 4 -> |6-3|, |3-4| -> MAD 2.
    assert experiment.mad(np.array([0.0, 3.0, 6.0, 3.0]), window=3) == pytest.approx(2.0)
    # Window 10: alternating +-1 has a running mean of 0 -> MAD 1; a ramp x_i = i lags its mean by 4.5.
    alternating = (-1.0) ** np.arange(40)
    ramp = np.arange(40, dtype=float)
    both = experiment.mad(np.column_stack([alternating, ramp, np.full(40, 7.0)]))
    assert both == pytest.approx([1.0, 4.5, 0.0])
    with pytest.raises(ValueError):
        experiment.mad(np.zeros(5))


def test_schedule_scales_every_phase() -> None:
    total, record_from, ramp = experiment.schedule(0.001)
    assert (total, record_from, ramp) == (5000, 3000, experiment.RAMP)
    total, record_from, ramp = experiment.schedule(0.001, 1.0)
    assert (total, record_from) == (1000, 600) and ramp == pytest.approx(0.2)
    start, goal = np.zeros(2), np.array([1.0, -2.0])
    assert experiment.ramp(start, goal, 100, 0.001, 0.2) == pytest.approx([0.5, -1.0])
    assert experiment.ramp(start, goal, 900, 0.001, 0.2) == pytest.approx(goal)


@cache
def _run(engine: str, duration: float | None) -> tuple[experiment.Setup, Result]:
    setup, results = run_grid(VARIANT, [engine], [None], duration)
    return setup, results[0]


def test_mujoco_physical_inertia_is_still() -> None:
    setup, result = _run("mujoco", None)
    assert result.status == STATUS_OK, result.note
    assert set(result.mad) == set(setup.joints) and len(setup.actuated) == 15
    # The index servo presses at the driver's effort limit (0.18 N m), where its force is clipped: its
    # joints' MAD is ~2e-10 rad (validate's contact_stability bound is 1e-9).
    assert max(result.mad.values()) <= 1e-9
    assert result.force_mean > 1.0 and result.contact_share == 1.0
    assert result.reached and result.coupling_residual <= 1e-3
    assert result.settings["timestep"] == 0.001


# Known (issue 15): with the driver's efforts (0.18-0.88 N m) pybullet's POSITION_CONTROL motors stall
# on channels tied to JOINT_GEAR constraints, so Bullet's hand never reaches the test pose.
BULLET_STALLS = pytest.mark.xfail(reason="pybullet motors stall at the driver's efforts through gears", strict=True)


@pytest.mark.parametrize("engine", ["mujoco", "dart", pytest.param("bullet", marks=BULLET_STALLS), "drake"])
def test_engine_runs_and_honours_couplings(engine: str) -> None:
    setup, result = _run(engine, SHORT)
    if result.status == STATUS_MISSING:
        pytest.skip(result.note)
    assert result.status == STATUS_OK, result.note
    assert result.settings["timestep"] == pytest.approx(0.001)
    assert result.simulated_s == pytest.approx(SHORT)
    assert len(result.qpos) == 1000 and np.isfinite(result.qpos).all()
    # The coupled joints really move (the test pose flexes the middle, ring and pinky fingers) and
    # follow their channels while the hand travels; the fingertip then reaches the surface.
    index = [setup.joints.index(c.joint) for c in setup.couplings]
    assert np.abs(result.qpos[:, index]).max() > 0.3
    assert result.coupling_residual_free <= 1e-2
    assert result.contact_share > 0 and result.force_mean > 0
    assert np.isfinite(result.mad_average)


def test_missing_engine_is_reported_not_raised(tmp_path) -> None:
    # A child process in which pybullet cannot be imported (None in sys.modules blocks the import).
    script = (
        "import sys; sys.modules['pybullet'] = None\n"
        "from svhdesc.cli import main\n"
        "main(['compare', '--engines', 'bullet,mujoco', '--inertias', 'physical', '--duration', '0.3',"
        f" '--json', {str(tmp_path / 'r.json')!r}, '--csv', {str(tmp_path / 'r.csv')!r}])\n"
    )
    run = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=120)
    assert run.returncode == 0, run.stderr
    assert "not installed (pip install pybullet)" in run.stdout
    results = {r["engine"]: r for r in json.loads((tmp_path / "r.json").read_text())["results"]}
    assert results["bullet"]["status"] == STATUS_MISSING
    assert results["mujoco"]["status"] == STATUS_OK
    rows = list(csv.DictReader((tmp_path / "r.csv").open()))
    mujoco_rows = [r for r in rows if r["engine"] == "mujoco"]
    assert len(mujoco_rows) == len(results["mujoco"]["mad_rad"]) == 26  # one row per joint
    assert [r["status"] for r in rows if r["engine"] == "bullet"] == [STATUS_MISSING]


def test_cli_rejects_bad_input() -> None:
    for args in (["nope"], ["--engines", "gazebo"], ["--inertias", "heavy"], ["--inertias", "-1"]):
        run = subprocess.run(
            [sys.executable, "-m", "svhdesc.cli", "compare", *args], capture_output=True, text=True, timeout=60
        )
        assert run.returncode == 2 and run.stderr.startswith("error:"), (args, run.stderr)
        assert "Traceback" not in run.stderr


def test_explosion_is_detected_and_reported() -> None:
    from svhdesc.compare.report import summary
    from svhdesc.compare.runner import STATUS_BLEW_UP, _exploded

    home = np.zeros(3)
    assert _exploded(np.array([0.1, -0.2]), home, home) is None
    assert _exploded(np.array([0.1, np.nan]), home, home) == "NaN"
    assert "rad" in _exploded(np.array([0.1, 80.0]), home, home)
    assert " m away" in _exploded(np.zeros(2), np.array([0.0, 0.0, 9.0]), home)
    failed = Result("bullet", 0.001, STATUS_BLEW_UP, note="NaN at t = 1.234 s", failed_at=1.234)
    assert "blew up at 1.23 s" in summary([failed])


def test_adapter_interface_at_home() -> None:
    import svhdesc
    from svhdesc.compare.engine import RunConfig
    from svhdesc.compare.mujoco_engine import MujocoEngine, finger_links, servo

    mjcf = svhdesc.get(VARIANT).mjcf_path
    setup = experiment.define(mjcf)
    links = finger_links(mjcf)
    assert "right_hand_t" in links and "wrist_3_link" not in links
    engine = MujocoEngine()
    engine.load(RunConfig(VARIANT, setup, 0.01, links, servo(mjcf, 0.01, links, setup.actuated)))
    assert engine.joint_positions() == pytest.approx(setup.home_qpos)
    assert engine.coupling_residual(setup) == pytest.approx(0.0, abs=1e-12)
    engine.step(setup.home_ctrl)
    assert engine.fingertip_force() == 0.0  # far from the surface at home
    assert np.linalg.norm(engine.fingertip_position() - setup.tip_test_position) > 0.3
    finger = engine.model.body("right_hand_t").id
    assert engine.model.body_inertia[finger] == pytest.approx([0.01] * 3)
