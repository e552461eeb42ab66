"""A trained policy through the ROS 2 node, as it would drive the real hand, beside the same policy in process.

    python benchmarks/learn_deploy.py TASK [--episodes N] [--policy docs/results/learn_TASK.onnx] [--via PATH ...]

For each of ``N`` seeds, one whole episode each way: ``svhdesc deploy TASK --policy P --seed S --via V`` for each
path ``V`` (``trajectory``: a JointTrajectory point per control period on the trajectory controllers' topic, the
driver's configuration as SCHUNK ships it; ``forward``: the forward position controllers switched in), the task's
scene served by the ROS 2 node in real time and the policy node closing the loop with the tracker, inside a private
network namespace (ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST); and the same actor, seed and start state run in process
on the main model (MuJoCo C, the task's environment). Writes docs/results/learn_<task>_ros2.md: each episode's
success and score every way, and their means.
"""

from __future__ import annotations

import argparse
import json
import shlex
import subprocess
import sys
import tempfile
from pathlib import Path
from typing import Any

BENCHMARKS = Path(__file__).resolve().parent
REPO = BENCHMARKS.parent
sys.path[:0] = [str(BENCHMARKS), str(REPO)]

from results import RESULTS, write  # noqa: E402
from sim_bench_ros2 import BenchError, namespace, ros2_python  # noqa: E402

from svhdesc.errors import SvhdescError  # noqa: E402
from svhdesc.learn.deploy import VIA  # noqa: E402
from tests.ros2.support import private_env  # noqa: E402

TITLES = {"trajectory": "trajectory topic", "forward": "forward controller"}


def through_ros2(task: str, policy: Path, seed: int, via: str, python: Path, unshare: list[str]) -> dict[str, Any]:
    with tempfile.TemporaryDirectory(prefix="learn-deploy-") as scratch:
        command = f"{shlex.quote(str(python))} -m svhdesc.cli deploy {task} --policy {shlex.quote(str(policy))}"
        script = f"ip link set lo up && cd {shlex.quote(str(REPO))} && exec {command} --seed {seed} --via {via}"
        result = subprocess.run(
            [*unshare, "sh", "-c", script], env=private_env(Path(scratch)), capture_output=True, text=True, timeout=900
        )
    lines = [line for line in result.stdout.splitlines() if line.startswith("{")]
    if result.returncode != 0 or not lines:
        tail = (result.stderr.strip().splitlines() or ["(no output)"])[-1]
        raise BenchError(f"svhdesc deploy {task} --seed {seed} --via {via} exited {result.returncode}: {tail}")
    return json.loads(lines[-1])


def in_process(task: Any, policy: Path, seed: int) -> dict[str, Any]:
    import torch

    from svhdesc.learn.deploy import nominal
    from svhdesc.learn.env import TaskEnv
    from svhdesc.learn.policy import OnnxPolicy

    act = OnnxPolicy(policy, task)
    env = TaskEnv(nominal(task), 1, backend="mujoco", source="main", seed=seed)
    env.stats.clear()
    done = torch.zeros(1, dtype=torch.bool)
    while not bool(done[0]):  # the episode's statistics are taken as it ends (a drop, or its time out)
        _, _, done, _ = env.step(torch.as_tensor(act(env.observe()[0].numpy())))
    stats = env.stats.read()
    score = stats["score"] if task.score is not None else None
    return {"success": stats["success"] == 1.0, "score": score}


def _figure(value: float | None) -> str:
    return "-" if value is None else f"{value:.3g}"


Row = tuple[int, dict[str, dict[str, Any]]]  # seed, {way: {success, score}}


def _mean(rows: list[Row], way: str, key: str) -> float:
    return sum(float(ways[way][key]) for _, ways in rows) / len(rows)


def _means(task: Any, rows: list[Row], ways: list[str]) -> list[str]:
    name = task.score_name or "score"
    local = "in process"
    success = "; ".join(f"{TITLES.get(w, w)}: {_mean(rows, w, 'success'):.2f}" for w in ways)
    lines = [f"- Success: {success} ({len(rows)} episodes each)."]
    if task.score is not None:
        reference = _mean(rows, local, "score")
        parts = []
        for way in ways:
            score = _mean(rows, way, "score")
            ratio = f" ({score / reference:.2f} of in process)" if reference and way != local else ""
            parts.append(f"{TITLES.get(way, way)}: {score:.3g}{ratio}")
        lines.append(f"- Mean {name}: {'; '.join(parts)}.")
    return lines


def page(task: Any, policy: Path, paths: list[str], rows: list[Row]) -> Path:
    name = task.score_name or "score"
    ways = [*paths, "in process"]
    body = [
        f"{task.name}: {task.summary}. The actor {policy.name} for one whole episode ({task.episode_s:g} s) per seed, "
        "through the ROS 2 node in real time (`svhdesc deploy`: tracker, policy node at the task's control rate on "
        "simulated time) and in process on the main model (MuJoCo C) from the same start state. Through ROS 2 "
        "each way the policy node can command the servos: the **trajectory topic** (`--via trajectory`, the "
        "default: one JointTrajectory point per control period on `/<controller>/joint_trajectory` of the active "
        "trajectory controllers, nothing switched: the driver's configuration as SCHUNK ships it) and the "
        "**forward controller** (`--via forward`: the forward position controllers switched in, "
        "`/<controller>/commands`).",
        "",
        "| seed | " + " | ".join(f"{TITLES.get(w, w)}: success | {TITLES.get(w, w)}: {name}" for w in ways) + " |",
        "|---|" + "---|---|" * len(ways),
    ]
    for seed, results in rows:
        cells = [f"{'yes' if results[w]['success'] else 'no'} | {_figure(results[w].get('score'))}" for w in ways]
        body.append(f"| {seed} | " + " | ".join(cells) + " |")
    body += ["", *_means(task, rows, ways)]
    body += [
        "",
        "What differs between the ways: through ROS 2 the policy observes what the node publishes (joint positions, "
        "the tracker's poses, the object's velocities differenced from them) one transport hop late, and its "
        "commands reach the servos at the node's next update; in process it reads the simulation's state directly. "
        "Through the trajectory topic each target is a point due one control period after it is sent, which the "
        "trajectory controller interpolates to; the forward controller sets it at once.",
    ]
    return write(f"learn_{task.name}_ros2", f"{task.name} through the ROS 2 node", body)


def main(argv: list[str]) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("task")
    parser.add_argument("--episodes", type=int, default=4)
    parser.add_argument("--policy", type=Path, default=None)
    parser.add_argument("--via", choices=VIA, action="append", help="a path through ROS 2 (default: both)")
    args = parser.parse_args(argv)
    paths = args.via or list(VIA)
    try:
        from svhdesc.learn import task as find_task

        task = find_task(args.task)
        policy = args.policy or RESULTS / f"learn_{task.name}.onnx"
        if not policy.is_file():
            raise BenchError(f"{policy}: no such policy (benchmarks/learn_bench.py {task.name} keeps one)")
        if args.episodes < 1:
            raise BenchError(f"--episodes must be at least 1, not {args.episodes}")
        python, unshare = ros2_python(), namespace()
        rows: list[Row] = []
        for seed in range(1, args.episodes + 1):
            results = {via: through_ros2(task.name, policy.resolve(), seed, via, python, unshare) for via in paths}
            results["in process"] = in_process(task, policy, seed)
            print(f"seed {seed}: {results}", flush=True)
            rows.append((seed, results))
    except (BenchError, SvhdescError) as error:
        print(f"error: {error}", file=sys.stderr)
        return 2
    print(f"wrote {page(task, policy, paths, rows)}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
