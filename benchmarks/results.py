"""Where benchmark scripts put their figures: docs/results/<name>.md, headed by command, machine and date.

benchmarks/collect.py builds benchmarks/README.md from these files, so no figure is re-typed.
"""

from __future__ import annotations

import datetime
import os
import platform
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
RESULTS = REPO / "docs" / "results"
FIELDS = ("command", "machine", "date")


def cpu_model() -> str:
    """The CPU's model name (Linux /proc/cpuinfo), else what platform knows."""
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or platform.machine()


def command() -> str:
    """How this script was started, relative to the repository: what a reader reruns."""
    return "python " + " ".join([os.path.relpath(sys.argv[0], REPO), *sys.argv[1:]])


def header(title: str) -> list[str]:
    date = datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d %H:%M UTC")
    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
    return [
        f"# {title}",
        "",
        f"- command: `{command()}`",
        f"- machine: {cpu_model()}, {os.cpu_count()} cores, load average {load:.1f} at the start of writing",
        f"- date: {date}",
        "",
    ]


def fields(text: str) -> dict[str, str]:
    """The header's command, machine and date, as ``header`` wrote them."""
    found = {}
    for line in text.splitlines():
        for key in FIELDS:
            if line.startswith(f"- {key}: ") and key not in found:
                found[key] = line.split(": ", 1)[1]
    return found


def write(name: str, title: str, body: list[str], folder: Path | None = None) -> Path:
    """Write <folder, default docs/results>/<name>.md (header + body lines) and return its path."""
    folder = folder or RESULTS
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / f"{name}.md"
    path.write_text("\n".join([*header(title), *body]) + "\n")
    return path
