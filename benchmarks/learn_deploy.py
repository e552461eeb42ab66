"""A trained policy through the ROS 2 node, as it would drive the real hand, beside the same policy in process.

    python benchmarks/learn_deploy.py TASK [--episodes N] [--policy docs/results/learn_TASK.onnx]

For each of ``N`` seeds, one whole episode: ``svhdesc deploy TASK --policy P --seed S`` (the task's scene served by
the ROS 2 node in real time, the policy node closing the loop through the forward position controllers and the
tracker; inside a private network namespace, ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST), and the same actor, seed and
start state run in process on the main model (MuJoCo C, the task's environment). Writes
docs/results/learn_<task>_ros2.md: each episode's success and score both ways, and their means.
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
from tests.ros2.support import private_env  # noqa: E402


def through_ros2(task: str, policy: Path, seed: int, python: Path, unshare: list[str]) -> dict[str, Any]:
    with tempfile.TemporaryDirectory(prefix="learn-deploy-") as scratch:
        command = f"{shlex.quote(str(python))} -m svhdesc.cli deploy {task} --policy {shlex.quote(str(policy))}"
        script = f"ip link set lo up && cd {shlex.quote(str(REPO))} && exec {command} --seed {seed}"
        result = subprocess.run(
            [*unshare, "sh", "-c", script], env=private_env(Path(scratch)), capture_output=True, text=True, timeout=900
        )
    lines = [line for line in result.stdout.splitlines() if line.startswith("{")]
    if result.returncode != 0 or not lines:
        tail = (result.stderr.strip().splitlines() or ["(no output)"])[-1]
        raise BenchError(f"svhdesc deploy {task} --seed {seed} exited {result.returncode}: {tail}")
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


def page(task: Any, policy: Path, rows: list[tuple[int, dict[str, Any], dict[str, Any]]]) -> Path:
    name = task.score_name or "score"
    body = [
        f"{task.name}: {task.summary}. The actor {policy.name} for one whole episode ({task.episode_s:g} s) per seed: "
        "through the ROS 2 node in real time (`svhdesc deploy`: forward position controllers, tracker, policy node "
        "at the task's control rate on simulated time), and in process on the main model (MuJoCo C) from the same "
        "start state.",
        "",
        f"| seed | ROS 2: success | ROS 2: {name} | in process: success | in process: {name} |",
        "|---|---|---|---|---|",
    ]
    for seed, ros, local in rows:
        body.append(
            f"| {seed} | {'yes' if ros['success'] else 'no'} | {_figure(ros.get('score'))} | "
            f"{'yes' if local['success'] else 'no'} | {_figure(local['score'])} |"
        )
    n = len(rows)
    ros_success = sum(r["success"] for _, r, _ in rows) / n
    local_success = sum(lo["success"] for _, _, lo in rows) / n
    body += ["", f"- Success through ROS 2: {ros_success:.2f}; in process: {local_success:.2f} ({n} episodes)."]
    if task.score is not None:
        ros_score = sum(r["score"] for _, r, _ in rows) / n
        local_score = sum(lo["score"] for _, _, lo in rows) / n
        ratio = f" ({ros_score / local_score:.2f} of it)" if local_score else ""
        body.append(f"- Mean {name} through ROS 2: {ros_score:.3g}; in process: {local_score:.3g}{ratio}.")
    body += [
        "",
        "What differs between the two: through ROS 2 the policy observes what the node publishes (joint positions, "
        "the tracker's poses, the object's velocities differenced from them) one transport hop late, and its "
        "commands reach the servos at the node's next update; in process it reads the simulation's state directly.",
    ]
    return write(f"learn_{task.name}_ros2", f"{task.name} through the ROS 2 node", body)


def main(argv: list[str]) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("task")
    parser.add_argument("--episodes", type=int, default=4)
    parser.add_argument("--policy", type=Path, default=None)
    args = parser.parse_args(argv)
    try:
        from svhdesc.learn import task as find_task

        task = find_task(args.task)
        policy = args.policy or RESULTS / f"learn_{task.name}.onnx"
        if not policy.is_file():
            raise BenchError(f"{policy}: no such policy (benchmarks/learn_bench.py {task.name} keeps one)")
        if args.episodes < 1:
            raise BenchError(f"--episodes must be at least 1, not {args.episodes}")
        python, unshare = ros2_python(), namespace()
        rows = []
        for seed in range(1, args.episodes + 1):
            ros = through_ros2(task.name, policy.resolve(), seed, python, unshare)
            local = in_process(task, policy, seed)
            print(f"seed {seed}: ROS 2 {ros}, in process {local}", flush=True)
            rows.append((seed, ros, local))
    except (BenchError, SvhdescError) as error:
        print(f"error: {error}", file=sys.stderr)
        return 2
    print(f"wrote {page(task, policy, rows)}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
