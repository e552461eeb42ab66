"""The test suite's time: the whole suite and the fast set (-m "not slow"), counts and times as pytest reports them.

    python benchmarks/suite_time.py                      # both, in this checkout; writes docs/results/tests.md
    python benchmarks/suite_time.py --fresh              # also ../shared/tools/fresh-readme test: a fresh clone
                                                         # with empty caches, the install included
    python benchmarks/suite_time.py --only tests/test_docs.py --out /tmp/t -- -n 0   # a subset, more pytest args

Each run is `python -m pytest -q -p no:cacheprovider` (pyproject's addopts: one xdist worker per core) in a process
of its own, with its own test-run folder. Run it on an otherwise idle machine: the times move with the load and the
CPU; the load average before each run is in its row. Not a test: machines are noisy.
"""

from __future__ import annotations

import argparse
import os
import re
import subprocess
import sys
import time
from dataclasses import dataclass
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO / "benchmarks"))
from results import RESULTS, write  # noqa: E402

FRESH = REPO.parent / "shared" / "tools" / "fresh-readme"
FULL_TARGET_S = 10 * 60  # everything, in a checkout or a fresh clone (pytest time, idle 2-core machine)
FAST_TARGET_S = 2 * 60  # the fast set, in a checkout
# pytest's last line: "623 passed, 1 xfailed, 3 warnings in 323.45s (0:05:23)".
SUMMARY = re.compile(r"(\d+ (?:passed|failed|errors?|skipped|xfailed|xpassed|deselected)\b[^\n]*?) in ([\d.]+)s\b")
PROSE = [
    "",
    "`pytest time` is what pytest reports for its session; `wall` is the whole process (start-up and, for the fresh",
    'clone, the install) as the script timed it. The fast set (`-m "not slow"`) is for development; the README\'s',
    "command and CI run everything. The slow tests are marked by path in `tests/conftest.py` and one by one with",
    "`@pytest.mark.slow` where a module holds quick tests beside them.",
]


@dataclass
class Run:
    label: str
    command: str
    outcome: str
    pytest_s: float | None
    wall_s: float
    load: float
    target_s: float | None
    rc: int


def minutes(seconds: float | None) -> str:
    if seconds is None:
        return "-"
    whole = round(seconds)
    if whole < 60:
        return f"{seconds:.1f} s"
    return f"{whole // 60} min" + (f" {whole % 60} s" if whole % 60 else "")


def summary(output: str) -> tuple[str, float | None]:
    """pytest's counts and its session time, from the last summary line in ``output``."""
    found = SUMMARY.findall(output)
    if not found:
        return "no pytest summary", None
    counts, seconds = found[-1]
    return counts.strip(" =").removesuffix(",").strip(), float(seconds)


def timed(label: str, argv: list[str], shown: str, target_s: float | None, cwd: Path = REPO) -> Run:
    env = {k: v for k, v in os.environ.items() if k != "SVHDESC_TEST_RUN"}  # a test run of its own
    load = os.getloadavg()[0]
    print(f"--- {label}: {shown}", flush=True)
    began = time.perf_counter()
    result = subprocess.run(argv, cwd=cwd, env=env, capture_output=True, text=True)
    wall = time.perf_counter() - began
    output = result.stdout + result.stderr
    print(output[-2000:], flush=True)
    outcome, seconds = summary(output)
    return Run(label, shown, outcome, seconds, wall, load, target_s, result.returncode)


def row(run: Run) -> str:
    checked = run.pytest_s if run.pytest_s is not None else run.wall_s
    if run.target_s is None:
        target = "(subset: no target)"
    else:
        target = f"<= {minutes(run.target_s)} {'met' if run.rc == 0 and checked <= run.target_s else 'MISSED'}"
    outcome = run.outcome + ("" if run.rc == 0 else f" (exit {run.rc})")
    return (
        f"| {run.label} | `{run.command}` | {outcome} | {minutes(run.pytest_s)} | {minutes(run.wall_s)} "
        f"| {run.load:.1f} | {target} |"
    )


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--only", nargs="+", default=[], metavar="PATH", help="time these test paths only")
    parser.add_argument("--fresh", action="store_true", help=f"also {FRESH} test (a fresh clone, empty caches)")
    parser.add_argument("--out", type=Path, default=RESULTS, help="folder for tests.md (default docs/results)")
    parser.add_argument("pytest_args", nargs="*", help="more pytest arguments for every run, after --")
    args = parser.parse_args()
    base = ["-m", "pytest", "-q", "-p", "no:cacheprovider", *args.pytest_args, *args.only]
    shown = " ".join(["python", *base])
    subset = bool(args.only)
    runs = []
    if args.fresh:
        if not FRESH.is_file():
            print(f"error: --fresh: {FRESH} not found", file=sys.stderr)
            return 2
        command = [str(FRESH), "test"]
        runs.append(timed("fresh clone, empty caches", command, "../shared/tools/fresh-readme test", FULL_TARGET_S))
    runs.append(timed("everything", [sys.executable, *base], shown, None if subset else FULL_TARGET_S))
    fast = [sys.executable, *base, "-m", "not slow"]
    runs.append(timed("fast set", fast, f'{shown} -m "not slow"', None if subset else FAST_TARGET_S))
    body = [
        f"Targets (pytest time, an idle 2-core machine): {minutes(FULL_TARGET_S)} for everything, in a checkout or a "
        f"fresh clone, {minutes(FAST_TARGET_S)} for the fast set."
        + (f" Only {', '.join(args.only)} was timed here: no target applies." if subset else ""),
        "",
        "| run | command | tests | pytest time | wall | load average before | target |",
        "|---|---|---|---|---|---|---|",
        *map(row, runs),
        *PROSE,
    ]
    path = write("tests", "Test suite time", body, args.out)
    print("\n".join(body))
    print(f"wrote {path}")
    return 0 if all(run.rc == 0 for run in runs) else 1


if __name__ == "__main__":
    sys.exit(main())
