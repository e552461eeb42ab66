"""Tabular epsilon-greedy Q-learning and the training loop of the paper's Algorithm 1.

The Q table is a dict from state (an int, see :mod:`.env`) to a list of 6 action values; a state is added, with
zeros, the first time it is seen. Ties in argmax go to the first action (as MATLAB's ``max`` does), so a
greedy run is deterministic. All randomness comes from one ``random.Random(seed)``.
"""

from __future__ import annotations

import random
import time
from collections.abc import Callable
from dataclasses import dataclass, field

from svhdesc.wireloop.env import CCW, CW, HIT, OUT, Environment, Snapshot

# Why an episode ended.
HIT_WIRE, LEFT_AREA, LOST_OBJECTIVE = "hit_wire", "left_area", "lost_objective"
COMPLETED, STALLED = "completed", "stalled"  # stalled: no objective reached within the patience


@dataclass(frozen=True)
class AgentConfig:
    alpha: float = 0.5  # paper
    gamma: float = 0.5  # paper
    episodes: int = 50  # N_e, training episodes per cycle (paper)
    cycles: int = 200  # N_c, at most (paper); training stops once a greedy run from the start completes
    epsilon_init: float = 1.0
    epsilon_min: float = 0.05
    stop_when_solved: bool = True  # False: keep training all N_c cycles, from the start once solved


@dataclass
class Episode:
    """What one run of the loop did."""

    outcome: str
    steps: int
    best: int  # farthest index along the wire of a reached objective (or of the end)
    stable: Snapshot  # the last place an objective was reached before the stop (the start if none)
    cells: list[int] = field(default_factory=list)  # (cell * 4 + rotation) per step, when traced
    actions: list[int] = field(default_factory=list)


@dataclass
class TrainingResult:
    q: dict[int, list[float]]
    distances: list[int]  # covered distance (pixels along the wire) after each cycle's test phase
    solved_cycle: int | None  # first cycle after which a greedy run from the start completes the wire
    wall_s: float
    episodes_run: int
    steps_run: int


def run_episode(
    env: Environment,
    q: dict[int, list[float]],
    start: Snapshot,
    epsilon: float,
    rng: random.Random | None,
    alpha: float = 0.5,
    gamma: float = 0.5,
    learn: bool = True,
    trace: bool = False,
    script: list[int] | None = None,
) -> Episode:
    """One episode from ``start``: epsilon-greedy if ``epsilon`` > 0, updating ``q`` with eq. 1 if ``learn``.

    ``script``: take these actions instead of choosing (for tests of the rules); the episode ends with
    outcome ``stalled`` when they run out before a stop.
    """
    return _walk(env, q, start, _policy(script, epsilon, rng), (alpha, gamma) if learn else None, trace)


def _walk(
    env: Environment,
    q: dict[int, list[float]],
    start: Snapshot,
    choose: Callable[[int, list[float]], int | None],
    learning: tuple[float, float] | None,
    trace: bool,
) -> Episode:
    """The episode's loop: `choose` picks each action; eq. 1 updates `q` with `learning`'s (alpha, gamma)."""
    # ~10^4 steps per training: the tables live in locals (the rewards of rare events are read where they happen).
    cfg = env.config
    transition, pattern = env.transition, env.pattern
    objective_index, offset = env.objective_index, env.objective_offset
    end, index, patience, r_step = env.end, env.index, cfg.patience, cfg.reward_step
    limit = 4 * len(env.path_cells) + 100  # a hard cap as well: objectives reached going back and forth
    alpha, gamma = learning or (0.0, 0.0)
    cell, rotation, objective = start.cell, start.rotation, start.objective
    direction, previous = start.direction, start.previous
    code = cell * 4 + rotation
    values = _row(q, pattern[cell] | objective_index[objective - cell + offset] << 25 | rotation << 30)
    stable, best = start, index.get(start.previous, 0)
    cells: list[int] = []
    actions: list[int] = []
    steps = idle = 0
    outcome = STALLED
    while (action := choose(steps, values)) is not None:
        steps += 1
        idle += 1
        nxt = transition[code * 6 + action]
        if trace:
            actions.append(action)
            cells.append(nxt)
        if nxt < 0:
            outcome = HIT_WIRE if nxt == HIT else LEFT_AREA
            reward, terminal = (cfg.reward_hit if nxt == HIT else cfg.reward_out), True
        else:
            code = nxt
            cell, rotation = nxt >> 2, nxt & 3
            if action < CW:
                direction = action
            reward, terminal = r_step, False
            if cell == end:
                reward, terminal, outcome, best = cfg.reward_done, True, COMPLETED, len(env.path_cells) - 1
            elif cell == objective:
                objective, previous = env.next_objective(cell, direction, objective, previous), objective
                reward, best, idle = cfg.reward_objective, max(best, index[cell]), 0
                stable = Snapshot(cell, rotation, objective, direction, previous)
            elif objective_index[objective - cell + offset] < 0:
                reward, terminal, outcome = cfg.reward_lost, True, LOST_OBJECTIVE
        if terminal:
            if learning:
                values[action] += alpha * (reward - values[action])
            break
        following = _row(q, pattern[cell] | objective_index[objective - cell + offset] << 25 | rotation << 30)
        if learning:
            values[action] += alpha * (reward + gamma * max(following) - values[action])
        values = following
        if idle >= patience or steps >= limit:
            break
    return Episode(outcome, steps, best, stable, cells, actions)


def _row(q: dict[int, list[float]], state: int) -> list[float]:
    """The state's action values; a state seen for the first time gets zeros."""
    values = q.get(state)
    if values is None:
        values = q[state] = [0.0] * 6
    return values


def _policy(
    script: list[int] | None, epsilon: float, rng: random.Random | None
) -> Callable[[int, list[float]], int | None]:
    """choose(steps taken, action values) -> the next action, or None when a script has run out."""
    if script is not None:
        return lambda steps, _values: script[steps] if steps < len(script) else None
    if epsilon:
        rand = rng.random

        def epsilon_greedy(_steps: int, values: list[float]) -> int:
            if rand() < epsilon:
                return int(rand() * 6)
            return values.index(max(values))

        return epsilon_greedy
    return lambda _steps, values: values.index(max(values))


def train(env: Environment, agent: AgentConfig | None = None, seed: int = 0) -> TrainingResult:
    """Algorithm 1: cycles of N_e epsilon-greedy episodes and a greedy test phase, from the stable position.

    The paper leaves open what follows a test phase that completes the wire (its stable position is then the
    end). Here a greedy run from the wire's start decides: if it completes the wire too, training stops (the
    agent solved the game); if not, the next cycle starts at that run's stable position.
    """
    agent = agent or AgentConfig()
    rng = random.Random(seed)
    q: dict[int, list[float]] = {}
    origin = env.start()
    init = origin
    distances: list[int] = []
    solved = None
    episodes = steps = 0
    decrement = 1.0 / agent.episodes
    alpha, gamma = agent.alpha, agent.gamma
    began = time.perf_counter()
    for cycle in range(1, agent.cycles + 1):
        epsilon = agent.epsilon_init
        for _ in range(agent.episodes):
            steps += run_episode(env, q, init, epsilon, rng, alpha, gamma).steps
            if epsilon > agent.epsilon_min:
                epsilon = max(agent.epsilon_min, epsilon - decrement)
        test = run_episode(env, q, init, 0.0, None, alpha, gamma)
        episodes += agent.episodes + 1
        steps += test.steps
        distances.append(test.best)
        init = test.stable
        if test.outcome == COMPLETED:
            check = run_episode(env, q, origin, 0.0, None, learn=False)
            steps += check.steps
            if check.outcome == COMPLETED:
                solved = solved or cycle
                if agent.stop_when_solved:
                    break
                init = origin
            else:
                init = check.stable
    wall = time.perf_counter() - began
    return TrainingResult(q, distances, solved, wall, episodes, steps)


def greedy_run(env: Environment, q: dict[int, list[float]], trace: bool = True) -> Episode:
    """The verification run: greedy from the wire's start, without learning (the Q table is not changed)."""
    probe = dict(q)  # unseen states get rows during the run; keep the caller's table as it was
    return run_episode(env, probe, env.start(), 0.0, None, learn=False, trace=trace)


def decide(env: Environment, q: dict[int, list[float]], cell: int, rotation: int, objective: int) -> int:
    """One greedy decision: state extraction, table lookup, argmax (what the per-action timing measures)."""
    values = q.get(env.state(cell, rotation, objective))
    if values is None:
        return 0
    return values.index(max(values))


__all__ = ["AgentConfig", "Episode", "TrainingResult", "run_episode", "train", "greedy_run", "decide", "CCW", "OUT"]
