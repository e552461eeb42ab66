"""The wire-and-loop planner (thesis Appendix A): map rules, environment rules, learning, CLI, MuJoCo run."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from svhdesc.errors import SvhdescError
from svhdesc.wireloop.agent import (
    COMPLETED,
    HIT_WIRE,
    LEFT_AREA,
    LOST_OBJECTIVE,
    STALLED,
    AgentConfig,
    greedy_run,
    run_episode,
    train,
)
from svhdesc.wireloop.env import CCW, CW, DOWN, HIT, LEFT, RIGHT, UP, Environment, Snapshot, objective_candidates
from svhdesc.wireloop.wiremap import builtin_path, load_map, parse_map
from tests.support import run_cli

# A straight wire on row 4: the loop starts at (4, 1) across it (rotation 2 = 90 degrees).
STRAIGHT = """
.........
.........
.........
.........
.S#####E.
.........
.........
.........
.........
"""
# The same wire two rows from the top edge: a limit leaves the map after one move up.
NEAR_EDGE = "\n".join(STRAIGHT.strip().splitlines()[2:])
# Wire down column 5 from (1, 5), then right along row 4: a corner at (4, 5).
CORNER = """
.........
.....S...
.....#...
.....#...
.....###E
.........
.........
.........
.........
"""


def env_of(text: str) -> Environment:
    return Environment(parse_map(text))


def scripted(env: Environment, actions: list[int], start: Snapshot | None = None):
    return run_episode(env, {}, start or env.start(), 0.0, None, learn=False, trace=True, script=actions)


# --- maps ---


@pytest.mark.parametrize(
    ("text", "match"),
    [
        ("..S#x#E..", "unexpected character 'x'"),
        ("S##E\n...", "row has 3 pixels"),
        ("S###S\n.....", "exactly one S and one E"),
        ("S##E\n.#..", "has 3 wire neighbours"),
        (".....\nS###E\n.....\n.###.\n.....", "needs 2"),
        ("S####\n....#\n.E###", "comes within 2 pixels"),
    ],
)
def test_bad_maps_name_the_culprit(text: str, match: str) -> None:
    with pytest.raises(SvhdescError, match=match):
        parse_map(text, "bad.txt")


def test_builtin_paths_ship_inside_the_package() -> None:
    for name in ("training", "test"):
        assert builtin_path(name).is_file()
        wire = load_map(name)
        assert wire.path[0] != wire.path[-1] and len(wire.path) > 50
    # The test path is a different wire, not the training one moved.
    assert load_map("training").path != load_map("test").path


# --- the environment's rules ---


def test_state_holds_wire_square_objective_and_rotation() -> None:
    env = env_of(STRAIGHT)
    start = env.start()
    assert env.row_col(start.cell) == (4, 1)
    assert start.rotation == 2  # across a horizontal wire
    assert env.row_col(start.objective) == (4, 3)  # the farthest cross point ahead on the wire
    # Square bits (row-major from the top-left, 5 x 5): the wire at offsets (0, 0), (0, 1), (0, 2).
    wire_bits = (1 << 12) | (1 << 13) | (1 << 14)
    assert env.state(start.cell, start.rotation, start.objective) == wire_bits | 14 << 25 | 2 << 30
    # Rotating changes only the rotation field; moving changes the square and the objective's place in it.
    turned = scripted(env, [CCW])
    code = turned.cells[0]
    assert env.state(code >> 2, code & 3, start.objective) == wire_bits | 14 << 25 | 3 << 30
    moved = scripted(env, [UP]).cells[0]
    assert env.state(moved >> 2, moved & 3, start.objective) == (1 << 17 | 1 << 18 | 1 << 19) | 19 << 25 | 2 << 30


def test_following_the_wire_reaches_objectives_and_completes() -> None:
    env = env_of(STRAIGHT)
    run = scripted(env, [RIGHT] * 6)
    assert run.outcome == COMPLETED and run.steps == 6 and run.best == 6
    # Stopping short: the last objective reached (4, 5) is the stable position, its successor (4, 7).
    short = scripted(env, [RIGHT] * 4)
    assert short.outcome == STALLED
    assert env.row_col(short.stable.cell) == (4, 5) and env.row_col(short.stable.objective) == (4, 7)


def test_limit_on_the_wire_stops() -> None:
    env = env_of(STRAIGHT)
    assert scripted(env, [UP]).outcome == STALLED  # one pixel off the wire: the wire is still inside the loop
    assert scripted(env, [UP, UP]).outcome == HIT_WIRE  # the lower limit lands on the wire
    middle = env.cell(4, 3)  # away from the map's edge, so turning along the wire stays inside it
    here = Snapshot(middle, 2, env.cell(4, 5), RIGHT, middle)
    assert scripted(env, [CCW], here).outcome == STALLED  # 135 degrees: limits clear of the wire
    assert scripted(env, [CCW, CCW], here).outcome == HIT_WIRE  # along the wire: both limits on it
    assert scripted(env, [CW], here).outcome == STALLED
    assert scripted(env, [CW, CW], here).outcome == HIT_WIRE
    # At the start, turning along the wire would also put a limit outside the map; leaving it is reported.
    assert scripted(env, [CCW, CCW]).outcome == LEFT_AREA


def test_a_rotation_that_sweeps_over_the_wire_stops() -> None:
    env = env_of(CORNER)
    middle = env.cell(5, 3)
    # Rotation 0 (limits at (5, 1) and (5, 5)) and rotation 1 (at (4, 4) and (6, 2)) are both clear of the wire,
    assert env.transition[(middle - 1) * 4 * 6 + 1 * 6 + RIGHT] == middle * 4 + 1
    assert env.transition[(middle + 1) * 4 * 6 + 0 * 6 + LEFT] == middle * 4 + 0
    # but turning between them sweeps a limit across the corner at (4, 5).
    assert env.transition[middle * 4 * 6 + 0 * 6 + CCW] == HIT
    assert env.transition[middle * 4 * 6 + 1 * 6 + CW] == HIT


def test_leaving_the_map_stops() -> None:
    env = env_of(NEAR_EDGE)
    assert scripted(env, [UP]).outcome == LEFT_AREA
    assert scripted(env, [DOWN]).outcome == STALLED


def test_objective_leaving_the_square_stops() -> None:
    env = env_of(STRAIGHT)
    assert scripted(env, [LEFT]).outcome == LOST_OBJECTIVE  # objective 3 pixels ahead now
    assert scripted(env, [UP, DOWN, DOWN]).outcome == STALLED  # sideways keeps it in the square


def test_objective_update_drops_the_opposite_side_and_takes_the_farthest() -> None:
    env = env_of(CORNER)
    corner = env.cell(4, 5)
    # Arriving at the corner moving down: the wire behind (up) is dropped; right is left, and the farthest of
    # the two right points wins.
    candidates = objective_candidates(env, corner, DOWN)
    assert sorted(env.row_col(c) for c in candidates) == [(4, 6), (4, 7)]
    assert env.row_col(env.next_objective(corner, DOWN, corner, env.cell(2, 5))) == (4, 7)
    # Arriving moving left (from off the wire, right of it): the right side is dropped, only up remains.
    candidates = objective_candidates(env, corner, LEFT)
    assert sorted(env.row_col(c) for c in candidates) == [(2, 5), (3, 5)]
    assert env.row_col(env.next_objective(corner, LEFT, corner, env.cell(4, 7))) == (2, 5)
    # Arriving moving up (from below): nothing on the wire is dropped; both far points tie at 2 pixels,
    # and the one farther from the previous objective wins.
    candidates = objective_candidates(env, corner, UP)
    assert sorted(env.row_col(c) for c in candidates) == [(2, 5), (3, 5), (4, 6), (4, 7)]
    assert env.row_col(env.next_objective(corner, UP, corner, env.cell(2, 5))) == (4, 7)
    assert env.row_col(env.next_objective(corner, UP, corner, env.cell(4, 7))) == (2, 5)
    # Arriving moving right drops everything to the left (nothing there) but keeps up and right.
    assert sorted(env.row_col(c) for c in objective_candidates(env, corner, RIGHT)) == [(2, 5), (3, 5), (4, 6), (4, 7)]
    # On the start of a wire, going right: only the wire ahead.
    straight = env_of(STRAIGHT)
    start = straight.cell(4, 1)
    assert sorted(straight.row_col(c) for c in objective_candidates(straight, start, RIGHT)) == [(4, 2), (4, 3)]
    assert objective_candidates(straight, start, LEFT) == []  # the only wire is on the dropped side


# --- learning ---


@pytest.fixture(scope="module")
def trained():
    env = Environment(load_map("training"))
    return env, train(env, AgentConfig(), seed=0)


def test_agent_solves_the_training_path_and_another(trained) -> None:
    env, result = trained
    assert result.solved_cycle is not None and result.solved_cycle <= 200
    assert result.distances[-1] == len(env.path_cells) - 1
    assert result.distances[0] < result.distances[-1]  # it learned: the first cycle did not get there
    assert greedy_run(env, result.q).outcome == COMPLETED
    other = Environment(load_map("test"))
    run = greedy_run(other, result.q)
    assert run.outcome == COMPLETED and run.best == len(other.path_cells) - 1


def test_training_is_reproducible_from_the_seed(trained) -> None:
    env, result = trained
    again = train(env, AgentConfig(), seed=0)
    assert again.q == result.q and again.distances == result.distances
    assert train(env, AgentConfig(), seed=1).q != result.q


# --- CLI ---


def test_cli_train_solve_round_trip(tmp_path: Path) -> None:
    first = run_cli("wireloop", "train", "--seed", "0", "--out", str(tmp_path / "a"))
    assert first.returncode == 0, first.stderr
    second = run_cli("wireloop", "train", "--seed", "0", "--out", str(tmp_path / "b"), cwd=tmp_path)
    assert second.returncode == 0, second.stderr
    for name in ("q_table.json", "distance.png"):
        assert (tmp_path / "a" / name).read_bytes() == (tmp_path / "b" / name).read_bytes()
    summary = json.loads((tmp_path / "a" / "summary.json").read_text())
    assert summary["solved"] and summary["cycles_to_solve"] == len(summary["distance_per_cycle"])
    assert summary["agent"]["episodes"] == 50 and summary["agent"]["alpha"] == 0.5
    policy = str(tmp_path / "a" / "q_table.json")
    for path in ("training", "test"):
        solved = run_cli("wireloop", "solve", "--policy", policy, "--path", path)
        assert solved.returncode == 0, solved.stderr
        assert "completed" in solved.stdout and "us per action" in solved.stdout
        assert (tmp_path / "a" / f"solve_{path}.png").stat().st_size > 1000


def test_cli_bad_input_is_one_error_line(tmp_path: Path) -> None:
    garbled_map = tmp_path / "garbled.txt"
    garbled_map.write_text("S#?#E\n")
    garbled_policy = tmp_path / "garbled.json"
    garbled_policy.write_text('{"format": "svhdesc-wireloop-q/1", "environment": {}, "q": [[1, [0, 1]]]}')
    cases = [
        (["train", "--path", str(tmp_path / "missing.txt"), "--out", str(tmp_path / "o")], "missing.txt"),
        (["train", "--path", str(garbled_map), "--out", str(tmp_path / "o")], "garbled.txt:1"),
        (["solve", "--policy", str(tmp_path / "missing.json")], "missing.json"),
        (["solve", "--policy", str(garbled_policy)], "garbled.json: q row 0"),
        (["train", "--episodes", "0", "--out", str(tmp_path / "o")], "--episodes"),
    ]
    for args, culprit in cases:
        result = run_cli("wireloop", *args)
        assert result.returncode == 2, (args, result.stderr)
        lines = result.stderr.strip().splitlines()
        assert len(lines) == 1 and lines[0].startswith("error:") and culprit in lines[0], lines


# --- MuJoCo ---


def test_mujoco_run_follows_a_short_plan_without_touching_the_wire(trained) -> None:
    from svhdesc.wireloop.mujoco_run import execute, plan_targets

    env, result = trained
    plan = greedy_run(env, result.q)
    poses = plan_targets(env, plan.cells, plan.actions)[:11]  # 10 moves, a rotation among them
    assert any(a >= CW for a in plan.actions[:10])
    run, scene = execute(env.map, poses)
    assert run.actions == 10 and run.sim_s >= 10 * 0.25
    assert not run.touched_wire and run.other_wire_contacts == 0
    assert 0 < run.min_clearance_m < scene.config.near
    assert run.worst_position_error_m < 0.003 and run.worst_yaw_error_deg < 3
    # The ring really went along: its centre ends over the 10th planned pixel.
    end = scene.world(poses[-1][0], poses[-1][1])
    assert sum((a - b) ** 2 for a, b in zip(run.centres[-1], end)) ** 0.5 < 0.002
