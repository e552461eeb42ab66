"""Speed of the ROS 2 node (``svhdesc sim VARIANT --ros2 --as-fast``) beside the bare ``mj_step`` rate.

    python benchmarks/sim_bench_ros2.py [WINDOW [VARIANT ...]]   # wall s timed per variant (default 5); default all

Per variant: bare mj_step on the scene (10 simulated s), as a real-time factor at the model's timestep, measured
just before and just after the node, their mean the reference; then the node as fast as it can, with every topic it
publishes subscribed by a separate rclpy process (benchmarks/ros2_bench_subscriber.py, ``raw=True`` subscriptions:
/clock and joint_states at 125 Hz, each controller's controller_state at 125 Hz, /rosout, /parameter_events; the
action topics through its ActionClients) while one goal per trajectory controller moves home -> test over 60 s, so
feedback flows. Node and subscriber run in the ROS 2 venv's Python (``.venv-ros2/bin/python`` of this checkout, or
$SVHDESC_ROS2_PYTHON) inside a private network namespace (``unshare -n``, loopback only) with
ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST. Goal (issue 25): node >= 0.8 of bare for every variant. Writes
docs/results/node_speed_ros2.md. Not a test: machines are noisy; the ratio is taken against a reference measured
around it. Bad arguments, or no unshare or ROS 2 venv: one ``error:`` line, exit 2.
"""

from __future__ import annotations

import json
import math
import os
import shlex
import shutil
import signal
import subprocess
import sys
import tempfile
from pathlib import Path
from typing import Any

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))
sys.path.insert(0, str(REPO / "benchmarks"))

from results import write  # noqa: E402
from sim_bench import bare_rate  # noqa: E402  the same reference as the ROS 1 page

import svhdesc  # noqa: E402
from svhdesc.model import NODE_NAME, ROS2_JTC_TYPE, ros2_joint_name  # noqa: E402
from tests.netns import private_namespace  # noqa: E402

GOAL = 0.8
GOAL_SECONDS = 60.0  # home -> test: long enough to keep feedback flowing through the window at as-fast rates
WARMUP = 2.0  # wall s between the goals and the window: discovery settles, the node reaches its pace
WALL = 60.0  # the most any one wait (discovery, an answer) takes, wall s
SUBSCRIBER = REPO / "benchmarks" / "ros2_bench_subscriber.py"


class BenchError(Exception):
    """What the user gets as one ``error:`` line."""


def ros2_python() -> Path:
    python = Path(os.environ.get("SVHDESC_ROS2_PYTHON", REPO / ".venv-ros2" / "bin" / "python"))
    if not python.is_file():
        raise BenchError(f"no ROS 2 Python at {python} (bash tools/install.sh ros2, or set SVHDESC_ROS2_PYTHON)")
    return python


def namespace() -> list[str]:
    """The command that makes a private network namespace (tests/netns.py)."""
    command = private_namespace()
    if isinstance(command, str):
        raise BenchError(command)
    return command


def arguments(argv: list[str]) -> tuple[float, list[str]]:
    try:
        window = float(argv[0]) if argv else 5.0
    except ValueError:
        raise BenchError(f"WINDOW must be a number of wall seconds, got {argv[0]!r}") from None
    if not 0 < window < math.inf:
        raise BenchError(f"WINDOW must be positive, got {argv[0]!r}")
    known = svhdesc.variants()
    variants = argv[1:] or list(known)
    unknown = [v for v in variants if v not in known]
    if unknown:
        raise BenchError(f"unknown variant(s) {', '.join(unknown)}; known: {', '.join(known)}")
    return window, variants


def goals(variant: str) -> dict[str, dict[str, Any]]:
    """One goal per trajectory controller of the variant's ros2_controllers.yaml: its joints to the test keyframe."""
    from svhdesc.ros2.node import controllers_file, read_controllers

    model = svhdesc.load_mujoco(variant)
    actuators = [model.actuator(i).name for i in range(model.nu)]
    test = {ros2_joint_name(a): float(v) for a, v in zip(actuators, model.key("test").ctrl)}
    _, types, parameters = read_controllers(controllers_file(variant))
    found = {}
    for name in types:
        joints = parameters[name].get("joints")
        if joints and types[name] == ROS2_JTC_TYPE:  # the forward controllers have no goals, no controller_state
            found[name] = {"joints": joints, "positions": [test[j] for j in joints], "seconds": GOAL_SECONDS}
    return found


def node_rate(variant: str, window: float, python: Path, unshare: list[str]) -> dict[str, Any]:
    """The subscriber's report: simulated s per wall s over ``window``, everything subscribed, goals running."""
    work = Path(tempfile.mkdtemp(prefix=f"svhdesc-bench-ros2-{variant}-"))
    spec = {"node": NODE_NAME, "window": window, "warmup": WARMUP, "wall": WALL, "goals": goals(variant)}
    (work / "spec.json").write_text(json.dumps(spec))
    py, log = shlex.quote(str(python)), shlex.quote(str(work / "node.log"))
    # The node is stopped however the subscriber ends (SIGINT, then SIGKILL after 5 s); the whole session is
    # killed below in any case.
    script = f"""
ip link set lo up
{py} -m svhdesc.cli sim {shlex.quote(variant)} --ros2 --as-fast > {log} 2>&1 &
node=$!
trap 'kill -KILL $node 2>/dev/null' EXIT
{py} {shlex.quote(str(SUBSCRIBER))} {shlex.quote(str(work / "spec.json"))} $node
kill -INT $node 2>/dev/null
for _ in $(seq 50); do kill -0 $node 2>/dev/null || break; sleep 0.1; done
"""
    env = {
        **os.environ,
        "PYTHONPATH": str(REPO),
        "ROS_AUTOMATIC_DISCOVERY_RANGE": "LOCALHOST",
        "ROS_LOG_DIR": str(work / "roslog"),
    }
    env.pop("ROS_DOMAIN_ID", None)
    process = subprocess.Popen(
        [*unshare, "sh", "-c", script], env=env, stdout=subprocess.PIPE, text=True, start_new_session=True
    )
    try:
        out, _ = process.communicate(timeout=window + WARMUP + 4 * WALL)
    except subprocess.TimeoutExpired:
        out = ""
    finally:
        try:
            os.killpg(process.pid, signal.SIGKILL)  # the node and the subscriber, whatever state they are in
        except ProcessLookupError:
            pass
        process.wait()
    lines = [line for line in out.splitlines() if line.startswith("{")]
    report = json.loads(lines[-1]) if lines else {"error": "the subscriber printed no report"}
    if "error" in report:
        tail = (work / "node.log").read_text()[-1500:] if (work / "node.log").exists() else ""
        raise BenchError(f"{variant}: {report['error']} (node log {work / 'node.log'}: {tail.strip()[-300:]!r})")
    shutil.rmtree(work, ignore_errors=True)
    return report


def received(report: dict[str, Any]) -> str:
    """Messages the subscriber took per wall second, the ActionClients' feedback apart."""
    wall = report["wall"]
    return f"{sum(report['messages'].values()) / wall:.0f} (+ {sum(report['feedback'].values()) / wall:.0f} feedback)"


def cpu(report: dict[str, Any]) -> str:
    """Bare mj_step's CPU per simulated second; the node's simulation thread's, its wait for a core, all threads'."""
    used = report["cpu"]
    return f"{report['bare_cpu']:.3f}, {used['main']:.3f} ({used['main_waiting']:.3f}), {used['all']:.3f}"


def page(window: float, rows: list[tuple[str, float, float, dict[str, Any]]], met: bool) -> list[str]:
    topics = sorted({t for *_, r in rows for t in r["messages"]})
    return [
        "Real-time factor of the ROS 2 node (`svhdesc sim VARIANT --ros2 --as-fast`) with every topic it publishes",
        "subscribed by a separate rclpy process (`benchmarks/ros2_bench_subscriber.py`, raw subscriptions, /clock",
        "read) and one goal per trajectory controller executing (home -> `test` over 60 s, so feedback flows),",
        "beside bare `mj_step` on the same physics (`sim_bench.py`'s reference: the node's scene, the servos'",
        "targets moving as the goals move them, 10 steps a call; measured just before and after the node, the mean).",
        f"Node and subscriber share a private network namespace; the node is timed over {window:g} s of wall time.",
        "Absolute figures move with the machine's load (see the header); the ratio less so.",
        "",
        "**CPU per simulated second** (Linux's /proc schedstat, over the window): bare `mj_step`; the node's",
        "simulation thread (physics, controllers, reading the state), in brackets the time it was runnable but",
        "waited for a core; all the node's threads (with the publishing thread and DDS's).",
        "",
        "| variant | bare `mj_step` | ROS 2 node | node / bare | messages received per wall s "
        "| CPU s / simulated s: bare, simulation thread (waiting for a core), all threads |",
        "|---|---|---|---|---|---|",
        *[
            f"| `{v}` | {b:.1f}x | {r['rate']:.1f}x | {r['rate'] / b:.2f} | {received(r)} | {cpu(r)} |"
            for v, b, _, r in rows
        ],
        "",
        "Topics subscribed: " + ", ".join(f"`{t}`" for t in topics) + "; the action topics through the ActionClients.",
        "",
        f"Goal: node / bare >= {GOAL} for every variant: **{'met' if met else 'NOT met'}** in this run.",
        "The ROS 1 node's figures: [node_speed.md](/docs/results/node_speed.md).",
    ]


def main() -> None:
    window, variants = arguments(sys.argv[1:])
    python, unshare = ros2_python(), namespace()
    rows = []
    print(f"{'variant':<16} {'bare':>8} {'node':>8} {'node/bare':>10} {'msgs/s':>8}")
    for variant in variants:
        before = bare_rate(variant, 10.0)
        report = node_rate(variant, window, python, unshare)
        after = bare_rate(variant, 10.0)
        bare, report["bare_cpu"] = 0.5 * (before[0] + after[0]), 0.5 * (before[1] + after[1])
        node = report["rate"]
        rows.append((variant, bare, node, report))
        rate = sum(report["messages"].values()) / report["wall"]
        print(f"{variant:<16} {bare:7.1f}x {node:7.1f}x {node / bare:10.2f} {rate:8.0f}", flush=True)
        per_topic = {t: round(n / report["wall"]) for t, n in report["messages"].items()}
        feedback = {c: round(n / report["wall"]) for c, n in report["feedback"].items()}
        print(f"  received per wall s: {per_topic}; feedback per wall s: {feedback}")
        print(f"  CPU s per simulated s: {cpu(report)}")
        if report["unsubscribed"]:
            print(f"  not subscribed (type not importable): {report['unsubscribed']}")
    met = all(node / bare >= GOAL for _, bare, node, _ in rows)
    title = "Simulation node speed: the ROS 2 node against bare mj_step"
    path = write("node_speed_ros2", title, page(window, rows, met))
    print(f"goal: node/bare >= {GOAL} for every variant: {'met' if met else 'NOT met'}; wrote {path.relative_to(REPO)}")


if __name__ == "__main__":
    try:
        main()
    except BenchError as exc:
        print(f"error: {exc}", file=sys.stderr)
        sys.exit(2)
