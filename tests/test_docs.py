"""The README and docs/: every relative link and image resolves (anchors included), the README stays at most
300 lines with the two set-up commands verbatim (the first two ```sh blocks with "install", as
../shared/tools/fresh-readme picks them; .ci/run runs the test one), the docs speak of the software and not of how
it was made, and the figures they state that the code defines (the number of validate checks, the batch
capacities) are the code's.

Pages under docs/results/ link from the repository root (/docs/...): benchmarks/collect.py copies them into
benchmarks/README.md, where a link relative to docs/results/ would break.

Seeded faults (test_the_checks_catch_seeded_faults): a broken link, a broken anchor, a broken image, a 301-line
README, a missing command and a process word, each in a small tree of its own, are each reported; so is a results
page linking relatively.
"""

from __future__ import annotations

import ast
import re
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
MAX_README_LINES = 300
MAIN_COMMAND = "bash tools/install.sh && .venv/bin/svhdesc build"
TEST_COMMAND = "bash tools/install.sh test && .venv/bin/python -m pytest -q"
PROCESS_WORDS = re.compile(
    r"\bissues? \d+|\bthis (stop|session|issue)\b|\bprevious (stop|session)\b|\bstop's machine\b", re.IGNORECASE
)
LINK = re.compile(r"!?\[[^\]]*\]\(\s*<?([^)\s>]+)>?(?:\s+\"[^\"]*\")?\s*\)")
FENCE = re.compile(r"^```.*?^```", re.MULTILINE | re.DOTALL)
CODE_SPAN = re.compile(r"`[^`\n]*`")


def doc_files(root: Path) -> list[Path]:
    """The Markdown a reader meets: the README, CONTRIBUTING and everything under docs/."""
    top = [root / name for name in ("README.md", "CONTRIBUTING.md") if (root / name).is_file()]
    return top + sorted((root / "docs").rglob("*.md"))


def prose(text: str) -> str:
    """The text without fenced blocks and code spans (a link shown as code is no link)."""
    return CODE_SPAN.sub("", FENCE.sub("", text))


def slug(heading: str) -> str:
    """GitHub's anchor for a heading: lower case, punctuation dropped, spaces to hyphens."""
    text = re.sub(r"[`*_]|\[([^\]]*)\]\([^)]*\)", r"\1", heading).strip().lower()
    return re.sub(r"[^\w\- ]", "", text).replace(" ", "-")


def anchors(path: Path) -> set[str]:
    found: set[str] = set()
    for line in FENCE.sub("", path.read_text(encoding="utf-8")).splitlines():
        if match := re.match(r"#{1,6}\s+(.*?)\s*#*\s*$", line):
            base = slug(match.group(1))
            name, n = base, 0
            while name in found:  # GitHub numbers repeated headings: x, x-1, x-2
                n += 1
                name = f"{base}-{n}"
            found.add(name)
    return found


def broken_links(path: Path, root: Path) -> list[str]:
    """Every relative link or image in ``path`` whose file, folder or heading does not exist."""
    problems = []
    for target in LINK.findall(prose(path.read_text(encoding="utf-8"))):
        if re.match(r"[a-z][a-z0-9+.-]*:", target):  # http:, https:, mailto:
            continue
        file_part, _, anchor = target.partition("#")
        # "/...": from the repository root, as GitHub reads it.
        base = root if file_part.startswith("/") else path.parent
        where = (base / file_part.lstrip("/")).resolve() if file_part else path
        if path.parent.name == "results" and file_part and not file_part.startswith("/"):
            problems.append(f"{path.relative_to(root)}: {target} (a results page links from the root: /docs/...)")
        if not where.exists():
            problems.append(f"{path.relative_to(root)}: {target} (no such file)")
        elif anchor and where.suffix == ".md" and anchor not in anchors(where):
            problems.append(f"{path.relative_to(root)}: {target} (no such heading)")
    return problems


def sh_install_blocks(readme: str) -> list[str]:
    """What fresh-readme runs: the ```sh blocks that contain "install", in order."""
    blocks = re.findall(r"```(?:sh|bash|console)\n(.*?)```", readme, re.S)
    return [b.strip() for b in blocks if "install" in b]


def readme_problems(root: Path) -> list[str]:
    text = (root / "README.md").read_text(encoding="utf-8")
    problems = []
    if len(text.splitlines()) > MAX_README_LINES:
        problems.append(f"README.md: {len(text.splitlines())} lines (at most {MAX_README_LINES})")
    if sh_install_blocks(text)[:2] != [MAIN_COMMAND, TEST_COMMAND]:
        problems.append(f"README.md: the first two sh blocks with 'install' are not {MAIN_COMMAND!r}, {TEST_COMMAND!r}")
    return problems


def process_words(path: Path, root: Path) -> list[str]:
    return [
        f"{path.relative_to(root)}:{n}: {match.group(0)!r}"
        for n, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1)
        if (match := PROCESS_WORDS.search(line))
    ]


def test_every_relative_link_and_image_resolves() -> None:
    problems = [p for path in doc_files(REPO) for p in broken_links(path, REPO)]
    assert not problems, "\n".join(problems)


def test_every_picture_in_docs_is_shown() -> None:
    """A picture moved out of the README must still be shown somewhere (nothing lost in the move)."""
    text = " ".join(path.read_text(encoding="utf-8") for path in doc_files(REPO))
    unshown = [p.name for p in sorted((REPO / "docs").glob("*.png")) if p.name not in text]
    assert not unshown, f"docs/ pictures no page shows: {unshown}"


def test_readme_is_short_and_has_the_two_commands_verbatim() -> None:
    assert not readme_problems(REPO)
    ci = (REPO / ".ci" / "run").read_text(encoding="utf-8").splitlines()
    assert TEST_COMMAND in ci, ".ci/run must run the README's test command verbatim"


def test_docs_speak_of_the_software() -> None:
    problems = [p for path in doc_files(REPO) for p in process_words(path, REPO)]
    assert not problems, "\n".join(problems)


def check_names() -> list[str]:
    """The names in validate's STAGES registry, read from the source (no import of the checks' engines)."""
    tree = ast.parse((REPO / "svhdesc" / "validate" / "runner.py").read_text(encoding="utf-8"))
    for node in tree.body:
        if isinstance(node, ast.AnnAssign) and getattr(node.target, "id", "") == "STAGES":
            return [name.value for stage in node.value.elts for name in stage.elts[1].elts]
    raise AssertionError("no STAGES in svhdesc/validate/runner.py")


def test_the_number_of_checks_is_the_registrys() -> None:
    names = check_names()
    for doc in ("README.md", "docs/validation.md"):
        stated = re.findall(r"(\d+) checks", (REPO / doc).read_text(encoding="utf-8"))
        assert stated and set(stated) == {str(len(names))}, f"{doc} says {stated} checks; STAGES has {len(names)}"
    listed = (REPO / "docs" / "validation.md").read_text(encoding="utf-8")
    assert all(f"{name}," in listed or f"{name} " in listed for name in names)


def test_batch_capacities_are_the_generated_files() -> None:
    text = " ".join((REPO / "docs" / "batch.md").read_text(encoding="utf-8").split())
    for variant in ("svh_right", "svh_left", "ur5_svh_right"):
        model = (REPO / "generated" / variant / f"{variant}_batch.xml").read_text(encoding="utf-8")
        nconmax, njmax = re.search(r'<size nconmax="(\d+)" njmax="(\d+)"/>', model).groups()
        assert f"nconmax {nconmax}, njmax {njmax}" in text, f"docs/batch.md: {variant} has {nconmax}/{njmax}"


def test_the_checks_catch_seeded_faults(tmp_path: Path) -> None:
    good = f"# T\n\n## A b\n\n```sh\n{MAIN_COMMAND}\n```\n\n```sh\n{TEST_COMMAND}\n```\n\n[ok](docs/x.md#c-d)\n"
    (tmp_path / "docs").mkdir()
    (tmp_path / "docs" / "x.md").write_text("# X\n\n## C `d`\n\n![pic](x.png) [up](../README.md#a-b)\n")
    (tmp_path / "docs" / "x.png").write_bytes(b"")
    (tmp_path / "README.md").write_text(good)
    assert not readme_problems(tmp_path)
    assert not [p for path in doc_files(tmp_path) for p in broken_links(path, tmp_path)]
    faults = {
        "a broken link": good + "[gone](docs/missing.md)\n",
        "a broken anchor": good + "[gone](docs/x.md#nowhere)\n",
        "a broken image": good + "![gone](docs/missing.png)\n",
        "a 301-line README": good + "line\n" * (MAX_README_LINES + 1 - len(good.splitlines())),
        "a missing command": good.replace(TEST_COMMAND, TEST_COMMAND.replace(" -q", "")),
        "a process word": good + "Measured on this stop's machine (issue 15).\n",
    }
    (tmp_path / "docs" / "results").mkdir()
    (tmp_path / "docs" / "results" / "r.md").write_text("[x](/docs/x.md) [y](../x.md)\n")
    assert [p for p in broken_links(tmp_path / "docs" / "results" / "r.md", tmp_path) if "../x.md" in p]
    for fault, text in faults.items():
        (tmp_path / "README.md").write_text(text)
        found = readme_problems(tmp_path) + broken_links(tmp_path / "README.md", tmp_path)
        found += process_words(tmp_path / "README.md", tmp_path)
        assert found, f"{fault} went unnoticed"
