"""Where a burst of FollowJointTrajectory goals is lost between an rclpy client and the ROS 2 node.

    python benchmarks/ros2_goal_burst.py [COUNT]     # goals per burst (default 300)

For each pair of service QoS depths (the node's action services: rclpy's default 10, or the node's REQUEST_DEPTH;
the client's: 10 or 1000) one fresh ``svhdesc sim svh_right --ros2`` and one client (tests/ros2/client.py --burst: no
svhdesc code) that sends COUNT goals at once from its executor's thread, every third naming an unknown joint (the
node rejects those in its goal callback and logs each), the others valid and preempting each other. Reported: how
long sending took, how many malformed goals the node logged (what reached its callbacks), how many goal responses
and results the client received. Then the same burst against a native server instead of the node:
benchmarks/ros2_native_action_server.c, rcl_action with its default options (what rclcpp_action, and so
ros2_controllers' JTC, creates: depth 10) taking requests in a wait-set loop and rejecting each at once, compiled here
with gcc against the ROS 2 venv's headers and libraries (rclcpp itself is not on PyPI); it reports the requests it
took. Everything runs in the ROS 2 venv inside a private network namespace (``unshare -n``, loopback only,
ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST). Writes docs/results/ros2_goal_burst.md. Bad arguments, or no unshare, ROS
2 venv, gcc or libpython3.11 (python3-dev): one ``error:`` line, exit 2.
"""

from __future__ import annotations

import json
import shlex
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path
from typing import Any

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))
sys.path.insert(0, str(REPO / "benchmarks"))

from results import write  # noqa: E402
from sim_bench_ros2 import BenchError, namespace, ros2_python  # noqa: E402

from svhdesc.model import get  # noqa: E402
from svhdesc.ros2.controller import REQUEST_DEPTH  # noqa: E402
from tests.ros2.support import CLIENT, private_env  # noqa: E402

VARIANT = "svh_right"
RCLPY_DEFAULT = 10  # rmw_qos_profile_services_default's depth: rclpy's and rcl_action's default
DEPTHS = ((RCLPY_DEFAULT, RCLPY_DEFAULT), (REQUEST_DEPTH, RCLPY_DEFAULT), (RCLPY_DEFAULT, 1000), (REQUEST_DEPTH, 1000))
# The node with its services' depth set before it starts (the CLI otherwise)
NODE = "import sys, svhdesc.ros2.controller as c\nfrom svhdesc.cli import main"


def count(argv: list[str]) -> int:
    try:
        value = int(argv[0]) if argv else 300
    except ValueError:
        raise BenchError(f"COUNT must be a whole number of goals, got {argv[0]!r}") from None
    if not 3 <= value <= 5000:
        raise BenchError(f"COUNT must be between 3 and 5000, got {value}")
    return value


def run_burst(goals: int, server: str, client_depth: int, python: Path, unshare: list[str]) -> tuple[dict, str]:
    """The client's report and the server's log: ``server`` (Python source run by the venv's Python) started, the
    burst sent by tests/ros2/client.py --burst, then the server stopped with SIGINT."""
    with tempfile.TemporaryDirectory(prefix="svhdesc-burst-") as folder:
        work = Path(folder)
        report, log = work / "report.json", work / "server.log"
        q = shlex.quote
        script = f"""
ip link set lo up
{q(str(python))} -c {q(server)} > {log} 2>&1 &
server=$!
{q(str(python))} {q(str(CLIENT))} --burst {q(str(get(VARIANT).directory))} {report} {goals} {client_depth} \
    > {work}/client.log 2>&1
kill -INT $server
wait $server
"""
        subprocess.run([*unshare, "sh", "-c", script], env=private_env(work), timeout=600, check=False)
        if not report.is_file():
            raise BenchError(f"the burst client wrote no report: {(work / 'client.log').read_text()[-500:]}")
        return json.loads(report.read_text()), (log.read_text() if log.is_file() else "")


def burst(goals: int, node_depth: int, client_depth: int, python: Path, unshare: list[str]) -> dict[str, Any]:
    node = NODE + f"\nsys.argv[1:] = ['sim', {VARIANT!r}, '--ros2']; c.REQUEST_DEPTH = {node_depth}; main()"
    found, log = run_burst(goals, node, client_depth, python, unshare)
    found.update(logged=log.count("goal rejected"), node_depth=node_depth, client_depth=client_depth)
    return found


NATIVE_SOURCE = REPO / "benchmarks" / "ros2_native_action_server.c"
LIBPYTHON = Path("/usr/lib/x86_64-linux-gnu/libpython3.11.so.1.0")  # the venv's message libraries reference Python


def build_native(python: Path, folder: Path) -> Path:
    """The native server, compiled against the ROS 2 venv's headers and libraries (the wheels' include/, lib/)."""
    venv = python.parent.parent
    if shutil.which("gcc") is None or not LIBPYTHON.is_file():
        raise BenchError(f"the native server needs gcc and {LIBPYTHON} (apt-get install gcc python3-dev)")
    includes = [f"-I{d}" for d in sorted((venv / "include").iterdir()) if d.is_dir()]
    binary = folder / "native_action_server"
    libraries = ["rcl_action", "rcl", "rcutils", "rmw", "control_msgs__rosidl_typesupport_c"]
    command = ["gcc", "-O2", "-o", str(binary), str(NATIVE_SOURCE), *includes, f"-L{venv / 'lib'}"]
    command += [f"-Wl,-rpath,{venv / 'lib'}", "-Wl,--allow-shlib-undefined", *(f"-l{name}" for name in libraries)]
    command.append("-lcontrol_msgs__rosidl_generator_c")
    built = subprocess.run(command, capture_output=True, text=True, check=False)
    if built.returncode != 0:
        raise BenchError(f"gcc could not build the native server: {built.stderr.strip().splitlines()[-1:]}")
    return binary


def native(goals: int, depth: int, binary: Path, python: Path, unshare: list[str]) -> dict[str, Any]:
    """The burst against the native server of ``depth`` (the venv's Python starts it: its .pth sets the library
    path the wheels need; LD_PRELOAD gives their Python-facing libraries the symbols they reference)."""
    server = f"import os; os.environ['LD_PRELOAD'] = {str(LIBPYTHON)!r}; os.execv({str(binary)!r}, ['s', '{depth}'])"
    found, log = run_burst(goals, server, 1000, python, unshare)
    taken = [line for line in log.splitlines() if line.startswith("taken ")]
    found.update(taken=int(taken[-1].split()[1]) if taken else None, server_depth=depth, client_depth=1000)
    return found


def page(goals: int, rows: list[dict[str, Any]], natives: list[dict[str, Any]]) -> list[str]:
    lines = [
        f"{goals} FollowJointTrajectory goals sent at once to `{VARIANT}`'s `right_hand` ({goals // 3} naming an "
        "unknown joint, rejected and logged by the node's goal callback; the others valid, each preempting the one "
        "before), from the client's executor thread. Depth: how many requests (node) or answers (client) the DDS "
        "readers of the action services keep (KEEP_LAST, reliable).",
        "",
        "| node depth | client depth | send (s) | malformed the node saw | goal responses | results of accepted |",
        "|---:|---:|---:|---:|---:|---:|",
    ]
    for r in rows:
        lines.append(
            f"| {r['node_depth']} | {r['client_depth']} | {r['send_seconds']:.3f} | {r['logged']} of {r['malformed']} "
            f"| {r['responses']} of {r['sent']} | {r['results']} of {r['accepted']} |"
        )
    lines += [
        "",
        "The same burst (client depth 1000) against `benchmarks/ros2_native_action_server.c`: rcl_action's server, as "
        "rclcpp_action creates it for ros2_controllers' JTC, taking requests in a wait-set loop and rejecting each at "
        "once.",
        "",
        "| server depth | send (s) | requests the server took | goal responses |",
        "|---:|---:|---:|---:|",
    ]
    for r in natives:
        lines.append(
            f"| {r['server_depth']} | {r['send_seconds']:.3f} | {r['taken']} of {r['sent']} "
            f"| {r['responses']} of {r['sent']} |"
        )
    return lines


def main() -> None:
    goals = count(sys.argv[1:])
    python, unshare = ros2_python(), namespace()
    rows = []
    for node_depth, client_depth in DEPTHS:
        row = burst(goals, node_depth, client_depth, python, unshare)
        rows.append(row)
        print(
            f"node depth {node_depth:>5}, client depth {client_depth:>5}: node saw {row['logged']}/{row['malformed']} "
            f"malformed, {row['responses']}/{row['sent']} responses, {row['results']}/{row['accepted']} results",
            flush=True,
        )
    natives = []
    with tempfile.TemporaryDirectory(prefix="svhdesc-native-") as folder:
        binary = build_native(python, Path(folder))
        for depth in (RCLPY_DEFAULT, REQUEST_DEPTH):
            row = native(goals, depth, binary, python, unshare)
            natives.append(row)
            print(
                f"native server depth {depth:>5}, client depth 1000: took {row['taken']}/{row['sent']}, "
                f"{row['responses']}/{row['sent']} responses",
                flush=True,
            )
    title = "A burst of goals to the ROS 2 node: where requests are lost"
    path = write("ros2_goal_burst", title, page(goals, rows, natives))
    print(f"wrote {path.relative_to(REPO)}")


if __name__ == "__main__":
    try:
        main()
    except BenchError as exc:
        print(f"error: {exc}", file=sys.stderr)
        sys.exit(2)
