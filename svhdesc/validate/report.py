"""Check results: one row per check (measured value, bound, status), a table and a JSON document."""

from __future__ import annotations

import json
import math
from dataclasses import asdict, dataclass, field
from typing import Any

PASS = "pass"
FAIL = "fail"
NOT_RUN = "not run"
# The check does not apply to this robot (no hand, no couplings, no keyframes, ...): listed with why, never a failure.
SKIPPED = "skipped"


@dataclass
class Check:
    """One check's result. ``data`` carries the figures behind ``value`` for the JSON report."""

    name: str
    status: str
    value: str = ""
    bound: str = ""
    detail: str = ""
    data: dict[str, Any] = field(default_factory=dict)
    # Set when the check could not run because an external tool is absent: --allow-missing-tools
    # tolerates exactly these, never a check that could not run for another reason.
    missing_tool: str | None = None
    # Extra text printed under the main table (e.g. the per-joint MAD table); the JSON has the figures.
    table: str = field(default="", repr=False)

    @property
    def passed(self) -> bool:
        return self.status == PASS

    def acceptable(self, allow_missing_tools: bool) -> bool:
        tolerated = allow_missing_tools and self.status == NOT_RUN and self.missing_tool is not None
        return self.passed or self.status == SKIPPED or tolerated


def verdict(ok: bool) -> str:
    return PASS if ok else FAIL


def not_run(name: str, reason: str, bound: str = "", missing_tool: str | None = None) -> Check:
    return Check(name, NOT_RUN, "-", bound, reason, missing_tool=missing_tool)


def skipped(name: str, reason: str, bound: str = "") -> Check:
    """A check that does not apply to this robot, and why (e.g. "no couplings")."""
    return Check(name, SKIPPED, "-", bound, reason)


def summary(problems: list[str], fallback: str, limit: int = 6) -> str:
    """The first ``limit`` problems, or ``fallback`` when there are none."""
    if not problems:
        return fallback
    return "; ".join(problems[:limit]) + (" ..." if len(problems) > limit else "")


def fmt(value: float, digits: int = 3) -> str:
    """Short engineering-style number for the table."""
    if value is None or (isinstance(value, float) and math.isnan(value)):
        return "nan"
    if value == 0:
        return "0"
    magnitude = abs(value)
    if 1e-3 <= magnitude < 1e4:
        return f"{value:.{digits + 1}g}"
    return f"{value:.{digits}e}"


@dataclass
class VariantReport:
    name: str
    urdf: str
    mjcf: str
    checks: list[Check] = field(default_factory=list)
    runtime_s: float = 0.0

    def failed(self, allow_missing_tools: bool = False) -> list[Check]:
        return [c for c in self.checks if not c.acceptable(allow_missing_tools)]

    @property
    def skipped(self) -> list[Check]:
        return [c for c in self.checks if c.status == SKIPPED]

    def to_dict(self) -> dict[str, Any]:
        return {
            "variant": self.name,
            "urdf": self.urdf,
            "mjcf": self.mjcf,
            "runtime_s": round(self.runtime_s, 3),
            "checks": [_jsonable({k: v for k, v in asdict(c).items() if k != "table"}) for c in self.checks],
        }


def _jsonable(value: Any) -> Any:
    """NaN/inf are not JSON: write them as strings so the file stays standard."""
    if isinstance(value, dict):
        return {str(k): _jsonable(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_jsonable(v) for v in value]
    if isinstance(value, float) and not math.isfinite(value):
        return str(value)
    if hasattr(value, "item") and callable(value.item):  # numpy scalars
        return _jsonable(value.item())
    return value


def table(rows: list[list[str]], header: list[str]) -> str:
    widths = [max(len(str(r[i])) for r in [header, *rows]) for i in range(len(header))]
    lines = ["  ".join(str(c).ljust(w) for c, w in zip(row, widths, strict=True)).rstrip() for row in [header, *rows]]
    lines.insert(1, "  ".join("-" * w for w in widths))
    return "\n".join(lines)


def render_report(report: VariantReport) -> str:
    # Upper case for what needs attention, so a failure stands out in a long table.
    rows = [
        [c.name, c.value, c.bound, c.status if c.status in (PASS, SKIPPED) else c.status.upper()] for c in report.checks
    ]
    text = [f"== {report.name}  ({report.mjcf}, {report.urdf})", table(rows, ["check", "measured", "bound", "status"])]
    for check in report.checks:
        if check.status not in (PASS, SKIPPED) and check.detail:
            text.append(f"  {check.name}: {check.detail}")
    if report.skipped:
        text.append("  skipped (not applicable): " + "; ".join(f"{c.name} ({c.detail})" for c in report.skipped))
    for check in report.checks:
        if check.table:
            text.append(f"\n{check.name}:\n{check.table}")
    text.append(f"({report.runtime_s:.1f} s)")
    return "\n".join(text)


def all_passed(reports: list[VariantReport]) -> str:
    """The closing line of a run whose every applicable check passed, counting those skipped."""
    skipped = sum(len(r.skipped) for r in reports)
    applicable = f"; {skipped} skipped as not applicable, listed above" if skipped else ""
    return f"all checks passed ({len(reports)} model(s){applicable})"


def write_json(reports: list[VariantReport], path: Any, allow_missing_tools: bool) -> None:
    document = {
        "passed": all(not r.failed(allow_missing_tools) for r in reports),
        "allow_missing_tools": allow_missing_tools,
        "variants": [r.to_dict() for r in reports],
    }
    with open(path, "w", encoding="utf-8") as handle:
        json.dump(document, handle, indent=2)
        handle.write("\n")
