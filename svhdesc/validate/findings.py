"""Findings of validate on a file as it stands: each at its file:line, with the value that would pass where one does.

A model file's report is one row per check (pass, fail with its findings, skipped with why), rendered as text, JSON,
GitHub workflow commands or JUnit XML, filtered by a baseline of known findings.
"""

from __future__ import annotations

import hashlib
import json
import os
from dataclasses import asdict, dataclass, field
from pathlib import Path

from lxml import etree

from svhdesc.errors import SvhdescError

FORMATS = ("text", "json", "github", "junit")


@dataclass(frozen=True)
class Finding:
    check: str
    file: str
    line: int | None
    message: str
    remedy: str = ""

    def where(self) -> str:
        return f"{self.file}:{self.line}" if self.line else self.file

    def fingerprint(self) -> str:
        """What a baseline remembers: the file (relative), the check and the message, not the line, which moves
        with every edit above it."""
        text = f"{_relative(self.file)}\0{self.check}\0{self.message}"
        return hashlib.sha256(text.encode()).hexdigest()[:16]


@dataclass
class CheckResult:
    name: str
    status: str  # pass, fail, skipped
    findings: list[Finding] = field(default_factory=list)
    reason: str = ""
    figure: str = ""  # what was measured against the bound, where a check measures


@dataclass
class FileReport:
    path: str
    kind: str  # urdf, mjcf
    checks: list[CheckResult] = field(default_factory=list)
    seconds: float = 0.0

    @property
    def failed(self) -> list[CheckResult]:
        return [c for c in self.checks if c.status == "fail"]


def _relative(path: str) -> str:
    try:
        return Path(os.path.relpath(path)).as_posix()
    except ValueError:  # another drive on Windows
        return Path(path).as_posix()


def apply_baseline(reports: list[FileReport], baseline: Path) -> None:
    """Drop the findings the baseline knows; a check left without findings passes."""
    try:
        known = set(json.loads(baseline.read_text())["findings"])
    except (OSError, ValueError, KeyError, TypeError) as exc:
        raise SvhdescError(f"{baseline}: not a baseline written by --write-baseline ({exc})") from None
    for report in reports:
        for check in report.checks:
            if check.status != "fail":
                continue
            check.findings = [f for f in check.findings if f.fingerprint() not in known]
            if not check.findings:
                check.status = "pass"
                check.reason = "every finding is in the baseline"


def baseline_text(reports: list[FileReport]) -> str:
    prints = sorted({f.fingerprint() for r in reports for c in r.checks for f in c.findings})
    return json.dumps({"svhdesc_baseline": 1, "findings": prints}, indent=1) + "\n"


def render(reports: list[FileReport], fmt: str) -> str:
    return {"text": _text, "json": _json, "github": _github, "junit": junit}[fmt](reports)


def _all_findings(reports: list[FileReport]) -> list[tuple[Finding, str]]:
    """Every finding with its message as printed: the value that would pass appended where there is one."""
    return [
        (f, f.message + (f" (would pass: {f.remedy})" if f.remedy else ""))
        for report in reports
        for check in report.checks
        for f in check.findings
    ]


def _text(reports: list[FileReport]) -> str:
    lines = [f"{_relative(f.file)}:{f.line or 1}: {f.check}: {shown}" for f, shown in _all_findings(reports)]
    failed = sum(len(r.failed) for r in reports)
    findings = sum(len(c.findings) for r in reports for c in r.checks)
    lines.append(
        f"{len(reports)} model(s), {findings} finding(s) in {failed} failed check(s)"
        if failed
        else f"{len(reports)} model(s): all checks passed"
    )
    return "\n".join(lines) + "\n"


def _json(reports: list[FileReport]) -> str:
    return json.dumps([asdict(r) for r in reports], indent=1) + "\n"


def _escape_data(text: str) -> str:
    return text.replace("%", "%25").replace("\r", "%0D").replace("\n", "%0A")


def _escape_property(text: str) -> str:
    return _escape_data(text).replace(":", "%3A").replace(",", "%2C")


def _github(reports: list[FileReport]) -> str:
    """GitHub Actions workflow commands: each finding an annotation on its pull request's line."""
    lines = []
    for f, shown in _all_findings(reports):
        where = f"file={_escape_property(_relative(f.file))},line={f.line or 1}"
        title = _escape_property("svhdesc " + f.check)
        lines.append(f"::error {where},title={title}::{_escape_data(shown)}")
    return "\n".join(lines) + ("\n" if lines else "")


def junit(reports: list[FileReport]) -> str:
    """One testsuite per model, one testcase per check, a failure carrying its findings, a skip its reason."""
    suites = etree.Element("testsuites", name="svhdesc validate")
    for report in reports:
        suite = etree.SubElement(
            suites,
            "testsuite",
            name=_relative(report.path),
            tests=str(len(report.checks)),
            failures=str(len(report.failed)),
            skipped=str(sum(c.status == "skipped" for c in report.checks)),
            time=f"{report.seconds:.3f}",
        )
        for check in report.checks:
            case = etree.SubElement(suite, "testcase", classname=_relative(report.path), name=check.name)
            if check.status == "fail":
                failure = etree.SubElement(
                    case, "failure", message=check.findings[0].message if check.findings else check.reason
                )
                failure.text = "\n".join(
                    f"{f.where()}: {f.message}" + (f" (would pass: {f.remedy})" if f.remedy else "")
                    for f in check.findings
                )
            elif check.status == "skipped":
                etree.SubElement(case, "skipped", message=check.reason)
            if check.figure:
                etree.SubElement(case, "system-out").text = check.figure
    return etree.tostring(suites, pretty_print=True, xml_declaration=True, encoding="UTF-8").decode()
