"""urdfdom, yourdfpy and sdformat on a URDF or xacro as it stands (`svhdesc validate PATH`, static tier): the file as
the parsers its users' tools are built on read it, each where it is installed (one that is not is skipped, naming the
command that installs it).

- ``urdfdom``: ROS's own parser (robot_state_publisher, MoveIt, RViz), its ``check_urdf``, must exit 0.
- ``yourdfpy``: must load the file with every link and joint, and its ``validate()`` must hold.
- ``sdformat``: Gazebo's ``ign sdf -k`` must find the file valid, and its conversion (``ign sdf -p``) must keep every
  movable joint: SDFormat drops a massless link with its joint and every link below it (pybullet's fixed bases of
  mass 0 load as an empty model in Gazebo).

The external tools start together, in processes of their own, before the other checks read the file, and are
collected after them: a pre-commit hook waits for the slowest tool, not for their sum. A xacro goes to them expanded,
in a temporary folder. Over MAX_LINKS links they are not run (sdformat's conversion grows faster than the links):
skipped, with the count. A finding stands at the line of the link or joint the tool's message names, else at the
robot's.
"""

from __future__ import annotations

import functools
import logging
import re
import shutil
import subprocess
import tempfile
from dataclasses import dataclass, field
from pathlib import Path

from lxml import etree

from svhdesc.core.limits import MAX_LINKS
from svhdesc.validate.findings import CheckResult, Finding
from svhdesc.validate.parsers import (
    MEMORY_LIMIT,
    SDFORMAT_INSTALL,
    TIMEOUT,
    URDFDOM_INSTALL,
    _limit_memory,
)
from svhdesc.validate.static_urdf import UrdfSource

PARSER_CHECKS = ("urdfdom", "yourdfpy", "sdformat")
MOVING = ("revolute", "continuous", "prismatic")
_MISSING = re.compile(r"Tag <(\w+)> of (joint|link) is missing attribute '(\w+)'")
_COLOUR = re.compile(r"\x1b\[[0-9;]*m")
_NAMED = re.compile(r'name="([^"]+)"|(?:link|joint) named ([^\s.]+)|\[([^\]\s@]+)\]|\'([^\'\s]+)\'|"([^"\s]+)"')


@functools.cache
def _ign() -> str | None:
    """The `ign` front end, where its `sdf` subcommand is installed (asked once a process)."""
    tool = shutil.which("ign")
    if tool is None:
        return None
    try:
        result = subprocess.run([tool, "sdf", "--help"], capture_output=True, text=True, timeout=TIMEOUT, check=False)
    except OSError:
        return None
    return tool if result.returncode == 0 and "cannot find any available" not in result.stdout + result.stderr else None


@dataclass
class _Tool:
    """A tool started on the file: its process, or why it was not started."""

    process: subprocess.Popen[str] | None = None
    skipped: str = ""
    output: tuple[int, str, str] = field(default=(0, "", ""))

    def wait(self) -> tuple[int, str, str]:
        if self.process is None:
            return self.output
        try:
            out, err = self.process.communicate(timeout=TIMEOUT)
        except subprocess.TimeoutExpired:
            self.process.kill()
            self.process.communicate()
            return -9, "", f"stopped at the time limit of {TIMEOUT} s"
        if self.process.returncode and any(word in err + out for word in ("bad_alloc", "NoMemoryError")):
            err += f"\nout of memory at the limit of {MEMORY_LIMIT >> 30} GiB of address space"
        self.output, self.process = (self.process.returncode, out, err), None
        return self.output


def _start(args: list[str], cwd: Path) -> _Tool:
    process = subprocess.Popen(
        args,
        cwd=cwd,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        stdin=subprocess.DEVNULL,
        text=True,
        preexec_fn=_limit_memory,
    )
    return _Tool(process)


class Parsers:
    """The three parsers on one file: started by the constructor, judged by ``results``."""

    def __init__(self, source: UrdfSource, selected: set[str]) -> None:
        self.source = source
        self.tools: dict[str, _Tool] = {}
        self._folder: tempfile.TemporaryDirectory[str] | None = None
        wanted = [name for name in PARSER_CHECKS if name in selected]
        links = len(source.root.findall("link"))
        if not wanted:
            return
        if links > MAX_LINKS:
            why = f"{links} links, over the {MAX_LINKS} the parsers are run on (svhdesc/core/limits.py)"
            self.tools = {name: _Tool(skipped=why) for name in wanted}
            return
        path = self._file()
        if "urdfdom" in wanted:
            tool = shutil.which("check_urdf")
            self.tools["urdfdom"] = (
                _start([tool, str(path)], path.parent)
                if tool
                else _Tool(skipped=f"check_urdf not found; install with: {URDFDOM_INSTALL}")
            )
        if "sdformat" in wanted:
            ign = _ign()
            if ign is None:
                self.tools["sdformat"] = _Tool(skipped=f"ign sdf not found; install with: {SDFORMAT_INSTALL}")
            else:
                self.tools["sdformat"] = _start([ign, "sdf", "-k", str(path)], path.parent)
                self.tools["sdformat-p"] = _start([ign, "sdf", "-p", str(path)], path.parent)
        self.path = path
        self.wanted = wanted

    def _file(self) -> Path:
        """The URDF the tools read: the file itself, or a xacro's expansion in a temporary folder."""
        if not self.source.xacro_files:
            return self.source.path.resolve()
        self._folder = tempfile.TemporaryDirectory(prefix="svhdesc-parsers-")
        path = Path(self._folder.name) / f"{self.source.path.name.removesuffix('.xacro')}"
        path.write_bytes(etree.tostring(self.source.root, xml_declaration=True, encoding="utf-8"))
        return path

    def results(self) -> list[CheckResult]:
        try:
            out = []
            for name in PARSER_CHECKS:
                if name in self.tools and self.tools[name].skipped:
                    out.append(CheckResult(name, "skipped", reason=self.tools[name].skipped))
                elif name == "yourdfpy" and name in getattr(self, "wanted", ()):
                    out.append(self._yourdfpy())
                elif name in self.tools:
                    out.append(self._urdfdom() if name == "urdfdom" else self._sdformat())
            return out
        finally:
            for tool in self.tools.values():
                tool.wait()
            if self._folder is not None:
                self._folder.cleanup()

    def _finding(self, check: str, message: str) -> Finding:
        """At the link or joint the message names, else at the robot."""
        names = {e.get("name"): e for e in self.source.root if e.tag in ("link", "joint") and e.get("name")}
        named = next((names[n] for m in _NAMED.finditer(message) for n in m.groups() if n in names), None)
        file, line = self.source.where(named if named is not None else self.source.root)
        return Finding(check, file, line or self.source.root.sourceline, message)

    def _urdfdom(self) -> CheckResult:
        code, out, err = self.tools["urdfdom"].wait()
        if code == 0 and "Successfully Parsed XML" in out:
            root = next(line.split(":", 1)[1].split()[0] for line in out.splitlines() if line.startswith("root Link:"))
            return CheckResult("urdfdom", "pass", figure=f"check_urdf: root link {root}")
        return CheckResult(
            "urdfdom", "fail", [self._finding("urdfdom", f"check_urdf exits {code}: {_said(err + out)}")]
        )

    def _sdformat(self) -> CheckResult:
        code, out, err = self.tools["sdformat"].wait()
        invalid = "" if code == 0 and "Valid" in out else f"ign sdf -k exits {code}: {_said(err + out)}"
        converted_code, converted, _ = self.tools["sdformat-p"].wait()
        try:
            sdf = etree.fromstring(converted.encode()) if converted_code == 0 and converted.strip() else None
        except etree.XMLSyntaxError:
            sdf = None
        kept = {j.get("name") for j in sdf.iter("joint")} if sdf is not None else set()
        moving = [j for j in self.source.root.findall("joint") if j.get("type") in MOVING]
        dropped = [j for j in moving if j.get("name") not in kept] if sdf is not None else []
        if not dropped and not invalid:
            return CheckResult("sdformat", "pass", figure=f"valid; {len(kept)} joints kept of {len(moving)} movable")
        if not dropped:
            return CheckResult("sdformat", "fail", [self._finding("sdformat", invalid)])
        # One cause, one finding: the massless link, with what ign sdf -k then says of the model left.
        culprit = self._massless(dropped[0])
        what = f"link '{culprit.get('name')}' has no mass: " if culprit is not None else ""
        message = (
            f"Gazebo's SDFormat drops {len(dropped)} of {len(moving)} movable joints, '{dropped[0].get('name')}' "
            f"first: {what}SDFormat drops a link without mass, with its joint and the links below it"
            + (f" ({invalid})" if invalid else "")
        )
        file, line = self.source.where(culprit if culprit is not None else dropped[0])
        return CheckResult("sdformat", "fail", [Finding("sdformat", file, line, message)])

    def _massless(self, joint: etree._Element) -> etree._Element | None:
        """The link without mass that takes ``joint`` with it: its parent (a root of mass 0), else its child."""
        links = {link.get("name"): link for link in self.source.root.findall("link")}
        for end in ("parent", "child"):
            link = links.get(joint.find(end).get("link") if joint.find(end) is not None else None)
            mass = link.find("inertial/mass") if link is not None else None
            if link is not None and (mass is None or _mass(mass) <= 0.0):
                return link
        return None

    def _yourdfpy(self) -> CheckResult:
        try:
            import yourdfpy
        except ImportError:
            return CheckResult("yourdfpy", "skipped", reason="yourdfpy is not installed (pip install yourdfpy)")
        # yourdfpy logs its fallback to a second parser as errors: not the command line's to print (the xml check
        # reports the declaration that makes lxml refuse the file).
        quiet = logging.NullHandler()
        logging.getLogger("yourdfpy").addHandler(quiet)
        try:
            robot = yourdfpy.URDF.load(
                str(self.path), load_meshes=False, build_scene_graph=False, build_collision_scene_graph=False
            )
            valid = bool(robot.validate())
        except Exception as exc:  # noqa: BLE001 - any parser failure is the finding itself
            return CheckResult("yourdfpy", "fail", [self._finding("yourdfpy", f"{type(exc).__name__}: {exc}")])
        finally:
            logging.getLogger("yourdfpy").removeHandler(quiet)
        # validate() keeps its reasons, unlogged, in _errors (yourdfpy 0.0.5x); they name the tag, not the element.
        errors = list(dict.fromkeys(str(e) for e in getattr(robot, "_errors", []))) if not valid else []
        findings = [self._yourdfpy_finding(error) for error in errors[:5]]
        links, joints = len(self.source.root.findall("link")), len(self.source.root.findall("joint"))
        if (len(robot.link_map), len(robot.joint_map)) != (links, joints):
            read = f"{len(robot.link_map)} links and {len(robot.joint_map)} joints"
            findings.append(self._finding("yourdfpy", f"yourdfpy reads {read} of {links} and {joints}"))
        if not valid and not findings:
            findings.append(self._finding("yourdfpy", "validate() is false"))
        figure = f"{len(robot.link_map)} links, {len(robot.joint_map)} joints"
        return CheckResult("yourdfpy", "fail" if findings else "pass", findings, figure=figure)

    def _yourdfpy_finding(self, error: str) -> Finding:
        """``Tag <limit> of joint is missing attribute 'upper'``: at the first joint (or link) whose tag lacks it."""
        match = _MISSING.search(error)
        if match is None:
            return self._finding("yourdfpy", f"validate(): {error}")
        tag, owner, attribute = match.groups()
        element = next(
            (e for e in self.source.root.iterfind(f"{owner}/{tag}") if e.get(attribute) is None),
            None,
        )
        name = element.getparent().get("name") if element is not None else None
        message = f"validate(): {error}" + (f" (first: {owner} '{name}')" if name else "")
        file, line = self.source.where(element if element is not None else self.source.root)
        return Finding("yourdfpy", file, line or self.source.root.sourceline, message)


def _mass(element: etree._Element) -> float:
    try:
        return float(element.get("value", "0"))
    except ValueError:
        return 0.0


def _said(text: str, lines: int = 3) -> str:
    """The tool's first distinct errors (its warnings where it gives none), without colour codes, ign's banner or the
    source lines it cites."""
    kept: list[str] = []
    for raw in _COLOUR.sub("", text).splitlines():
        line = raw.strip()
        if line and "libignition-tools-backward" not in line and not line.startswith("at line") and line not in kept:
            kept.append(line)
    errors = [line for line in kept if "error" in line.lower()]
    return " | ".join((errors or kept)[:lines])
