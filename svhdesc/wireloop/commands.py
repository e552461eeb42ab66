"""What ``svhdesc wireloop train|solve`` do, apart from option parsing."""

from __future__ import annotations

import json
import time
from dataclasses import asdict, dataclass
from pathlib import Path

from svhdesc.errors import SvhdescError
from svhdesc.wireloop.agent import AgentConfig, Episode, greedy_run, train
from svhdesc.wireloop.env import Environment
from svhdesc.wireloop.policy import load_policy, save_policy
from svhdesc.wireloop.wiremap import load_map

POLICY_FILE, SUMMARY_FILE, CURVE_FILE = "q_table.json", "summary.json", "distance.png"


def train_to(out: Path, path: str, seed: int, episodes: int, cycles: int, plot: bool = True) -> dict[str, object]:
    """Train on ``path``; write the Q table, a JSON summary and the distance plot into ``out``."""
    if episodes < 1 or cycles < 1:
        raise SvhdescError("--episodes and --cycles must be at least 1")
    env = Environment(load_map(path))
    agent = AgentConfig(episodes=episodes, cycles=cycles)
    result = train(env, agent, seed)
    check = greedy_run(env, result.q, trace=False)
    summary: dict[str, object] = {
        "path": env.map.name,
        "wire_pixels": len(env.path_cells),
        "seed": seed,
        "agent": asdict(agent),
        "environment": asdict(env.config),
        "cycles_to_solve": result.solved_cycle,
        "solved": check.outcome == "completed",
        "cycles_run": len(result.distances),
        "episodes_run": result.episodes_run,
        "steps_run": result.steps_run,
        "states": len(result.q),
        "wall_s": round(result.wall_s, 6),
        "distance_per_cycle": result.distances,
    }
    out.mkdir(parents=True, exist_ok=True)
    meta = {k: summary[k] for k in ("path", "seed", "agent", "cycles_to_solve")}
    save_policy(out / POLICY_FILE, result.q, env.config, meta)
    (out / SUMMARY_FILE).write_text(json.dumps(summary, indent=2) + "\n", encoding="utf-8")
    if plot:
        from svhdesc.wireloop.plots import plot_distances

        title = f"{env.map.name}: seed {seed}, solved after {result.solved_cycle} cycles"
        plot_distances(result.distances, len(env.path_cells) - 1, out / CURVE_FILE, title)
    return summary


@dataclass
class Solve:
    env: Environment
    run: Episode
    per_action_s: float  # wall time of the whole greedy run / its actions, best of several runs
    decide_s: float  # one decision alone: state, lookup, argmax


def solve(policy: Path, path: str, repeats: int = 5) -> Solve:
    q, config = load_policy(policy)
    env = Environment(load_map(path), config)
    run = greedy_run(env, q)
    best = float("inf")
    for _ in range(repeats):
        began = time.perf_counter()
        timed = greedy_run(env, q, trace=False)
        best = min(best, (time.perf_counter() - began) / max(timed.steps, 1))
    return Solve(env, run, best, decision_time(env, q))


def decision_time(env: Environment, q: dict[int, list[float]], repeats: int = 5, n: int = 2000) -> float:
    """Best-of-``repeats`` mean time of one greedy decision at the wire's start."""
    start = env.start()
    state = env.state
    best = float("inf")
    for _ in range(repeats):
        began = time.perf_counter()
        for _ in range(n):
            values = q.get(state(start.cell, start.rotation, start.objective)) or [0.0]
            values.index(max(values))
        best = min(best, (time.perf_counter() - began) / n)
    return best


def run_mujoco(policy: Path, path: str, out: Path, actions: int | None, picture: bool = True) -> dict[str, object]:
    """Plan greedily with ``policy`` on ``path`` and execute the plan (or its first ``actions``) in MuJoCo."""
    from svhdesc.wireloop.mujoco_run import execute, plan_targets, render, summary

    q, config = load_policy(policy)
    env = Environment(load_map(path), config)
    plan = greedy_run(env, q)
    poses = plan_targets(env, plan.cells, plan.actions)
    if actions is not None:
        if actions < 1:
            raise SvhdescError("--actions must be at least 1")
        poses = poses[: actions + 1]
    run, _ = execute(env.map, poses)
    report: dict[str, object] = {"path": env.map.name, "plan_outcome": plan.outcome, **summary(run)}
    out.mkdir(parents=True, exist_ok=True)
    (out / "mujoco.json").write_text(json.dumps(report, indent=2) + "\n", encoding="utf-8")
    if picture:
        report["backend"] = render(path, run, out / "mujoco.png")
    return report
