"""Speed and learning figures of the wire-and-loop planner, beside the thesis' Appendix A.

    python benchmarks/wireloop_bench.py [--repeats 5] [--seeds 10]

Paper: "50 training episodes with 200 exploration cycles each", alpha = gamma = 0.5, 22.7 s of training in
MATLAB R2018a (Ryzen 9), solved after 24 training cycles; a verification run 110 ms on average (< 10 ms per
action). Both readings of the episode/cycle sentence are run. The time ratio against the paper compares
different maps (the paper's training path exists only as a figure) and, unless the paper stopped at 24
cycles too, different amounts of work: it is an order of magnitude, not a speed-up of the same job.
Times are best-of-N (the machine is shared, so the minimum is the figure least disturbed by other load).
Then a sweep of the details the paper leaves open, over several seeds.
"""

from __future__ import annotations

import argparse
import random
import statistics
import time
from dataclasses import replace

from svhdesc.errors import SvhdescError
from svhdesc.wireloop.agent import AgentConfig, greedy_run, train
from svhdesc.wireloop.commands import decision_time
from svhdesc.wireloop.env import EnvConfig, Environment
from svhdesc.wireloop.wiremap import load_map, parse_map

PAPER_TRAIN_S = 22.7
PAPER_CYCLES = 24
PAPER_VERIFY_S = 0.110
PAPER_ACTION_S = 0.010


def best_of(repeats: int, func) -> tuple[float, object]:
    best, value = float("inf"), None
    for _ in range(repeats):
        began = time.perf_counter()
        value = func()
        best = min(best, time.perf_counter() - began)
    return best, value


def speed(repeats: int) -> None:
    env = Environment(load_map("training"))
    test_env = Environment(load_map("test"))
    agent = AgentConfig()  # the paper's settings
    seconds, result = best_of(repeats, lambda: train(env, agent, seed=0))
    print(f"training path: {len(env.path_cells)} pixels; test path: {len(test_env.path_cells)} pixels")
    print(
        f"train (seed 0, N_e=50, N_c<=200, alpha=gamma=0.5): solved after {result.solved_cycle} cycles "
        f"(paper {PAPER_CYCLES}), {seconds * 1000:.1f} ms best of {repeats} "
        f"(paper {PAPER_TRAIN_S} s: {PAPER_TRAIN_S / seconds:.0f}x faster); "
        f"{result.episodes_run} episodes, {result.steps_run} steps, {len(result.q)} states, "
        f"{seconds / max(result.steps_run, 1) * 1e6:.2f} us per training step"
    )
    full = replace(agent, stop_when_solved=False)
    seconds_full, result_full = best_of(repeats, lambda: train(env, full, seed=0))
    print(
        f"train all 200 cycles (no stop once solved, restarting from the start): {seconds_full * 1000:.1f} ms "
        f"best of {repeats} ({PAPER_TRAIN_S / seconds_full:.0f}x faster than the paper), "
        f"{result_full.episodes_run} episodes, {result_full.steps_run} steps"
    )
    for name, target in (("training", env), ("test", test_env)):
        verify_s, run = best_of(repeats, lambda target=target: greedy_run(target, result.q, trace=False))
        per_action = verify_s / max(run.steps, 1)
        print(
            f"verify on the {name} path: {run.outcome}, {run.steps} actions in {verify_s * 1e3:.3f} ms "
            f"(paper {PAPER_VERIFY_S * 1e3:.0f} ms: {PAPER_VERIFY_S / verify_s:.0f}x), "
            f"{per_action * 1e6:.2f} us per action (paper < {PAPER_ACTION_S * 1e3:.0f} ms: "
            f"{PAPER_ACTION_S / per_action:.0f}x)"
        )
    decide = decision_time(env, result.q, repeats=repeats)
    print(f"one greedy decision alone (state, lookup, argmax): {decide * 1e6:.2f} us (target <= 100 us)")


def readings(seeds: int, repeats: int) -> None:
    """ "50 training episodes with 200 exploration cycles each", read both ways, over seeds.

    Chosen: N_e = 50 episodes per cycle, at most N_c = 200 cycles. Other: the 50 are Algorithm 1's outer
    cycles, each with 200 episodes (N_c = 50, N_e = 200; epsilon then falls by 1/200 per episode)."""
    env, other = Environment(load_map("training")), Environment(load_map("test"))
    print(f"\nthe two readings of '50 training episodes with 200 exploration cycles' (seeds 0..{seeds - 1}):")
    print(
        f"{'reading':<34} {'solved':>7} {'cycles median [min-max]':>24} {'episodes median':>16} "
        f"{'test path':>10} {'ms to solve (seed 0)':>21} {'ms all cycles (seed 0)':>23}"
    )
    for label, agent in (
        ("N_e 50 per cycle, N_c <= 200", AgentConfig(episodes=50, cycles=200)),
        ("N_e 200 per cycle, N_c <= 50", AgentConfig(episodes=200, cycles=50)),
    ):
        results = [train(env, agent, seed) for seed in range(seeds)]
        cycles = [r.solved_cycle for r in results if r.solved_cycle is not None]
        episodes = [r.episodes_run for r in results if r.solved_cycle is not None]
        tested = sum(greedy_run(other, r.q, trace=False).outcome == "completed" for r in results)
        solve_s, _ = best_of(repeats, lambda agent=agent: train(env, agent, seed=0))
        full_s, _ = best_of(repeats, lambda agent=agent: train(env, replace(agent, stop_when_solved=False), seed=0))
        spread = f"{statistics.median(cycles):.0f} [{min(cycles)}-{max(cycles)}]" if cycles else "-"
        median_episodes = f"{statistics.median(episodes):.0f}" if episodes else "-"
        print(
            f"{label:<34} {len(cycles):>3}/{seeds:<3} {spread:>24} {median_episodes:>16} {tested:>6}/{seeds:<3} "
            f"{solve_s * 1000:>21.1f} {full_s * 1000:>23.1f}"
        )


def sweep(seeds: int) -> None:
    print(f"\nsweep over seeds 0..{seeds - 1} (training path; paper settings unless named):")
    print(f"{'setting':<34} {'solved':>7} {'cycles median [min-max]':>24} {'test path solved':>17} {'ms/train':>9}")
    base = EnvConfig()
    cases: list[tuple[str, EnvConfig, AgentConfig]] = [
        ("chosen (radius 2, eps_min 0.05)", base, AgentConfig()),
        ("loop radius 1", replace(base, loop_radius=1), AgentConfig()),
        ("eps_min 0", base, AgentConfig(epsilon_min=0.0)),
        ("eps_min 0.2", base, AgentConfig(epsilon_min=0.2)),
        ("objective lost: 0 (not -5)", replace(base, reward_lost=0.0), AgentConfig()),
        ("objective reward 1 (not 10)", replace(base, reward_objective=1.0, reward_done=1.0), AgentConfig()),
        ("hit/out -1 (not -10)", replace(base, reward_hit=-1.0, reward_out=-1.0), AgentConfig()),
        ("patience 10 (not 20)", replace(base, patience=10), AgentConfig()),
    ]
    training, test = load_map("training"), load_map("test")
    for label, env_config, agent in cases:
        env = Environment(training, env_config)
        other = Environment(test, env_config)
        cycles, test_ok, times = [], 0, []
        for seed in range(seeds):
            began = time.perf_counter()
            result = train(env, agent, seed)
            times.append(time.perf_counter() - began)
            if result.solved_cycle is not None:
                cycles.append(result.solved_cycle)
            test_ok += greedy_run(other, result.q, trace=False).outcome == "completed"
        spread = f"{statistics.median(cycles):.0f} [{min(cycles)}-{max(cycles)}]" if cycles else "-"
        print(
            f"{label:<34} {len(cycles):>3}/{seeds:<3} {spread:>24} {test_ok:>9}/{seeds:<7} "
            f"{statistics.median(times) * 1000:>9.1f}"
        )


def random_maps(count: int, seed: int = 7) -> list:
    """Random wires of 6-10 pixel runs that start and end going right (the training path's start and end)."""
    rng = random.Random(seed)
    steps = {"R": (0, 1), "L": (0, -1), "U": (-1, 0), "D": (1, 0)}
    maps = []
    while len(maps) < count:
        runs = ["R"]
        for _ in range(rng.randint(5, 9)):
            runs.append(rng.choice("UD" if runs[-1] in "RL" else "LR"))
        if runs[-1] != "R":
            continue
        grid = [["."] * 36 for _ in range(26)]
        row, col = 3, 2
        pixels = [(row, col)]
        for run in runs:
            for _ in range(rng.randint(6, 10)):
                row, col = row + steps[run][0], col + steps[run][1]
                pixels.append((row, col))
        if len(set(pixels)) != len(pixels) or not all(2 < r < 23 and 1 < c < 33 for r, c in pixels):
            continue
        for r, c in pixels:
            grid[r][c] = "#"
        grid[3][2], grid[pixels[-1][0]][pixels[-1][1]] = "S", "E"
        try:
            maps.append(parse_map("\n".join("".join(line) for line in grid), f"random-{len(maps)}"))
        except SvhdescError:
            continue  # parts of the wire too close together
    return maps


def generalisation(seeds: int, count: int) -> None:
    env = Environment(load_map("training"))
    others = [Environment(m) for m in random_maps(count)]
    print(f"\ngeneralisation: {count} random wires (runs of 6-10 px), policies from the training path:")
    for seed in range(seeds):
        q = train(env, AgentConfig(), seed).q
        solved = sum(greedy_run(other, q, trace=False).outcome == "completed" for other in others)
        print(f"  seed {seed}: {solved}/{count} solved")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--seeds", type=int, default=10)
    args = parser.parse_args()
    speed(args.repeats)
    readings(args.seeds, args.repeats)
    sweep(args.seeds)
    generalisation(min(args.seeds, 5), 25)


if __name__ == "__main__":
    main()
