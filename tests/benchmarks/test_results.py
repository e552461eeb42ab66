"""docs/results/: every page carries the header benchmarks/results.py writes (the command of a script that exists in
benchmarks/, the machine, the date), benchmarks/README.md is what benchmarks/collect.py makes of the pages, and
benchmarks/suite_time.py counts and times what pytest ran.

Seeded faults: a page without the header, one naming a script benchmarks/ does not have, one with a hand-typed date,
and a header below the page's first lines are each reported (test_the_header_check_catches_seeded_faults); a failing
test turns the suite page's row into a failure with its count (test_suite_time_counts_what_pytest_ran).
"""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

from tests.benchmarks.scripts import BENCHMARKS, REPO, load

RESULTS = REPO / "docs" / "results"
COMMAND = re.compile(r"- command: `python ((?:benchmarks|examples)/[\w-]+\.py)( [^`]*)?`")
DATE = re.compile(r"- date: (\d{4}-\d\d-\d\d \d\d:\d\d UTC|not recorded\b.*)$")


def header_problems(page: Path, benchmarks: Path = BENCHMARKS) -> list[str]:
    """What is wrong with ``page``'s first five lines, against results.header's layout."""
    lines = [*page.read_text(encoding="utf-8").splitlines(), "", "", "", "", ""][:5]
    name = page.name
    problems = []
    if not lines[0].startswith("# ") or lines[1]:
        problems.append(f"{name}: no '# title' and blank line first")
    command = COMMAND.match(lines[2])
    if not command:
        problems.append(f"{name}: line 3 is not '- command: `python benchmarks/<script>.py ...`' (or examples/)")
    elif not (benchmarks.parent / command.group(1)).is_file():
        problems.append(f"{name}: {command.group(1)} does not exist")
    if not re.match(r"- machine: \S", lines[3]):
        problems.append(f"{name}: line 4 is not '- machine: ...'")
    if not DATE.match(lines[4]):
        problems.append(f"{name}: line 5 is not '- date: YYYY-MM-DD HH:MM UTC' (or 'not recorded ...')")
    return problems


def test_every_results_page_carries_the_header() -> None:
    pages = sorted(RESULTS.glob("*.md"))
    assert pages
    problems = [p for page in pages for p in header_problems(page)]
    assert not problems, "\n".join(problems)


def test_what_results_writes_passes_the_check(tmp_path: Path, monkeypatch) -> None:  # noqa: ANN001
    monkeypatch.setattr(sys, "argv", [str(BENCHMARKS / "bench.py"), "--quick"])
    results = load("results")
    page = results.write("x", "X", ["| a |", "|---|"], tmp_path)
    assert not header_problems(page)
    assert results.fields(page.read_text())["command"] == "`python benchmarks/bench.py --quick`"


def test_the_header_check_catches_seeded_faults(tmp_path: Path) -> None:
    good = "# T\n\n- command: `python benchmarks/bench.py --quick`\n- machine: a CPU, 2 cores\n- date: {}\n\nbody\n"
    cases = {
        "good": good.format("2026-01-02 03:04 UTC"),
        "not recorded": good.format("not recorded (rerun the command)"),
        "no header": "# T\n\n| a | b |\n|---|---|\n",
        "no such script": good.format("2026-01-02 03:04 UTC").replace("bench.py", "gone.py"),
        "a typed date": good.format("November 2026"),
        "a header further down": "# T\n\nSome text.\n\n" + good.format("2026-01-02 03:04 UTC")[5:],
    }
    found = {}
    for case, text in cases.items():
        (tmp_path / f"{case}.md").write_text(text)
        found[case] = header_problems(tmp_path / f"{case}.md")
    assert not found.pop("good") and not found.pop("not recorded")
    assert all(found.values()), f"unnoticed: {[case for case, problems in found.items() if not problems]}"


def test_readme_results_blocks_are_what_collect_makes_of_the_pages() -> None:
    """The project README's tables of figures (the parity table) are the pages' own: a figure typed into the README
    fails this (seeded: one cell of the parity block edited by hand)."""
    collect = load("collect")
    text = (REPO / "README.md").read_text(encoding="utf-8")
    assert "<!-- results:parity -->" in text
    assert text == collect.fill_blocks(text)


def test_benchmarks_readme_is_what_collect_makes_of_the_pages() -> None:
    """Run `python benchmarks/collect.py` after a script wrote a page."""
    assert (BENCHMARKS / "README.md").read_text(encoding="utf-8") == load("collect").render()


def test_suite_time_counts_what_pytest_ran(tmp_path: Path) -> None:
    """A subset of two tests, one failing, one slow, under a config of its own (no xdist workers: cheap)."""
    (tmp_path / "pytest.ini").write_text("[pytest]\nmarkers =\n    slow: long\n")
    test = tmp_path / "test_two.py"
    test.write_text("import pytest\n\ndef test_a():\n    assert False\n\n@pytest.mark.slow\ndef test_b():\n    pass\n")
    out = tmp_path / "out"
    argv = [sys.executable, str(BENCHMARKS / "suite_time.py"), "--only", str(test), "--out", str(out)]
    result = subprocess.run([*argv, "--", "-c", str(tmp_path / "pytest.ini")], capture_output=True, text=True)
    page = (out / "tests.md").read_text()
    assert result.returncode == 1, page
    assert not header_problems(out / "tests.md")
    rows = [line for line in page.splitlines() if line.startswith(("| everything", "| fast set"))]
    assert "| 1 failed, 1 passed (exit 1) |" in rows[0], rows
    assert "| 1 failed, 1 deselected (exit 1) |" in rows[1], rows
