"""`svhdesc validate PATH...`: robot files as they stand (a URDF, an MJCF, a folder of them), no config, no build.

Each file gets a FileReport; a file that cannot be read or parsed at all is one SvhdescError (exit 2) naming it.
"""

from __future__ import annotations

import os
import re
import stat
import sys
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path

import numpy as np
from lxml import etree

from svhdesc.core.limits import mesh_size_problem
from svhdesc.core.source.packages import package_map
from svhdesc.errors import SvhdescError
from svhdesc.validate.file_parsers import PARSER_CHECKS, Parsers
from svhdesc.validate.findings import CheckResult, FileReport, Finding
from svhdesc.validate.full_checks import FULL_CHECKS, run_full_checks
from svhdesc.validate.poses import is_position_servo
from svhdesc.validate.quirks import Quirks
from svhdesc.validate.sizes import unsimulated
from svhdesc.validate.static_urdf import RULES, UrdfSource

STATIC_MJCF_CHECKS = ("mjcf_compile", "actuator_ranges", "keyframes")
# A ctrlrange may pass its joint's range by what rounding leaves (gymnasium-robotics' Adroit hand writes -0.79 for a
# joint stopping at -0.785): 1 % of the range, not more.
ACTUATOR_SLACK = 0.01
# A keyframe may pass a limit by what printing qpos to a few digits leaves (1.26e-05 past 0 in gymnasium-robotics'
# kitchen), not by more: 1e-4 rad or m.
KEYFRAME_SLACK = 1e-4
TIERS = ("static", "full")
_SKIP_DIRS = {".git", ".hg", ".svn", "node_modules", "__pycache__", ".venv", "build", "install", "log"}


def known_checks() -> tuple[str, ...]:
    return ("xml", *RULES, *PARSER_CHECKS, *STATIC_MJCF_CHECKS, "mujoco_compile", *FULL_CHECKS)


def _parser() -> etree.XMLParser:
    # No entities, no network, no DTD loading: a validator runs on a pull request's files.
    return etree.XMLParser(resolve_entities=False, no_network=True, load_dtd=False, huge_tree=False)


def _regular(path: Path) -> None:
    try:
        mode = path.stat().st_mode
    except OSError as exc:
        raise SvhdescError(f"{path}: {exc.strerror.lower() if exc.strerror else exc}") from None
    if not stat.S_ISREG(mode):
        raise SvhdescError(f"{path}: not a regular file")


# XML declarations that libxml2 refuses and the robotics tools' parsers (TinyXML in urdfdom, pybullet, MuJoCo)
# accept: a version other than 1.x (pybullet_data writes version="0.0"), or a declaration after a comment.
_DECLARATION = re.compile(rb"<\?xml\b[^>]*\?>")
_TOLERATED = ("Unsupported version", "XML declaration allowed only at the start")


def read_xml(path: Path, tolerated: list[Finding] | None = None) -> etree._Element:
    """The file's root element. A declaration only libxml2 refuses is blanked (lines and columns kept) and, where
    ``tolerated`` is given, reported into it as an xml finding instead of stopping every check."""
    _regular(path)
    try:
        data = path.read_bytes()
    except OSError as exc:
        raise SvhdescError(f"{path}: cannot be read ({exc})") from None
    try:
        return etree.fromstring(data, _parser(), base_url=str(path))
    except etree.XMLSyntaxError as exc:
        line = exc.position[0] if exc.position else exc.lineno
        declaration = _DECLARATION.search(data)
        if tolerated is None or declaration is None or not any(t in exc.msg for t in _TOLERATED):
            raise SvhdescError(f"{path}:{line}: not well-formed XML ({exc.msg})") from None
        why = exc.msg.split(",")[0]
    blank = data[: declaration.start()] + b" " * len(declaration.group()) + data[declaration.end() :]
    root = read_xml_bytes(path, blank)
    line = data.count(b"\n", 0, declaration.start()) + 1
    tolerated.append(
        Finding(
            "xml",
            str(path),
            line,
            f"{declaration.group().decode(errors='replace')}: {why}; TinyXML-based tools read it, "
            "libxml2-based ones (lxml, xmllint, ROS 2's launch) refuse it",
            '<?xml version="1.0"?> as the first line, or no declaration',
        )
    )
    return root


def read_xml_bytes(path: Path, data: bytes) -> etree._Element:
    try:
        return etree.fromstring(data, _parser(), base_url=str(path))
    except etree.XMLSyntaxError as exc:
        line = exc.position[0] if exc.position else exc.lineno
        raise SvhdescError(f"{path}:{line}: not well-formed XML ({exc.msg})") from None


def robot_files(paths: list[Path]) -> list[tuple[Path, bool]]:
    """The files to validate, each with whether a folder's walk found it: each file given, and in each folder every
    *.urdf and every MJCF (*.xml rooted at <mujoco>) that no other file there includes, as a linter walks a tree."""
    found: list[tuple[Path, bool]] = []
    for path in paths:
        if path.is_dir():
            inside = _walk(path)
            if not inside:
                raise SvhdescError(f"{path}: no robot file in it (*.urdf, or *.xml rooted at <robot> or <mujoco>)")
            found.extend((p, True) for p in inside)
        else:
            _regular(path)
            other = _other_xml(path)
            if other is not None:  # a package.xml, a launch file: a hook passes every changed *.xml
                print(f"{path}: skipped, not a robot file (root <{other}>)", file=sys.stderr)
                continue
            found.append((path, False))
    return found


def _other_xml(path: Path) -> str | None:
    """The root tag of a *.xml rooted at neither <robot> nor <mujoco> (a fault after the root's start tag does not
    make it one); None for any other file, and for one whose root cannot be read, which validate_file names."""
    if path.suffix != ".xml":
        return None
    tag = root_tag(path)
    return None if tag in (None, "robot", "mujoco") else tag


def root_tag(path: Path) -> str | None:
    """The tag of the file's root element from its first start tag alone, None when that cannot be read."""
    try:
        # The stream is ours to close: iterparse left at its first event would leave a file it opened to the
        # garbage collector (a ResourceWarning on the command line).
        with path.open("rb") as stream:
            for _, element in etree.iterparse(stream, events=("start",), resolve_entities=False, no_network=True):
                return str(element.tag)
    except (etree.XMLSyntaxError, OSError):
        pass
    return None


def _walk(folder: Path) -> list[Path]:
    candidates = []
    for path in sorted(folder.rglob("*")):
        if any(part in _SKIP_DIRS or part.startswith(".") for part in path.relative_to(folder).parts[:-1]):
            continue
        if (path.suffix in {".urdf", ".xml"} or path.name.endswith(".urdf.xacro")) and path.is_file():
            candidates.append(path)
    roots: dict[Path, str] = {}
    included: set[Path] = set()
    for path in candidates:
        if is_xacro(path):  # a robot a xacro expands to; macro libraries (*.xacro alone) are only included
            roots[path] = "robot"
            continue
        try:
            root = etree.parse(str(path), _parser()).getroot()
        except (etree.XMLSyntaxError, OSError):
            if path.suffix == ".urdf":
                roots[path] = "robot"  # a broken URDF is still one to report
            continue
        roots[path] = root.tag if isinstance(root.tag, str) else ""
        if root.tag == "mujoco":
            included.update((path.parent / i.get("file", "")).resolve() for i in root.iter("include"))
    return [p for p, tag in roots.items() if tag == "robot" or (tag == "mujoco" and p.resolve() not in included)]


def _result(name: str, findings: list[Finding]) -> CheckResult:
    return CheckResult(name, "fail" if findings else "pass", findings)


def is_xacro(path: Path) -> bool:
    return path.suffix == ".xacro"


class _Packages(dict):  # type: ignore[type-arg]
    """--package NAME=DIR, then ROS_PACKAGE_PATH, then the folder above the model that is the package, as ROS finds
    $(find NAME) and package://NAME from a package's own tree."""

    def __init__(self, given: dict[str, Path], model: Path) -> None:
        super().__init__(package_map(given))
        self.model = model

    def __missing__(self, name: str) -> Path:
        from svhdesc.core.source.packages import find_beside

        found = find_beside(name, self.model)
        if found is None:
            raise KeyError(name)
        self[name] = found
        return found


def _read_robot(
    path: Path, packages: dict[str, Path], xacro_args: dict[str, str], tolerated: list[Finding]
) -> tuple[etree._Element, tuple]:
    """The file's root element, and the files a xacro expansion read (none for a plain file)."""
    if not is_xacro(path):
        return read_xml(path, tolerated), ()
    from svhdesc.core.source.xacro import expand_xacro

    _regular(path)
    with _regular_inputs():
        root, files = expand_xacro(path, xacro_args, _Packages(packages, path))
    return root, (path.resolve(), *(f for f in files if f != path.resolve()))


def _include_line(file: Path, name: str) -> int | None:
    """The line of the first element of ``file`` whose filename ends with ``name`` (an <xacro:include>, a load_yaml
    call in an attribute), or None."""
    try:
        root = etree.parse(str(file), _parser()).getroot()
    except (etree.XMLSyntaxError, OSError):
        return None
    for element in root.iter():
        if isinstance(element.tag, str) and any(
            value.rstrip("')}\" ").endswith(name) for value in element.attrib.values()
        ):
            return element.sourceline
    return None


@contextmanager
def _regular_inputs() -> Iterator[None]:
    """xacro's reads of the files a xacro includes (<xacro:include>, load_yaml) refused where the file is not a
    regular one: a FIFO or a device would block the read, or never end it."""
    import xacro

    def guarded(read: Callable[..., object], name: Callable[..., str | None]) -> Callable[..., object]:
        def guard(*args: object) -> object:
            named = name(*args)
            target = Path(os.path.join(xacro.root_dir, named)) if named else None
            if target is not None and target.exists() and not target.is_file():
                by = next((f for f in reversed(xacro.filestack or []) if f and f != named), "the xacro")
                where = f"{by}:{line}" if (line := _include_line(Path(by), target.name)) else by
                raise SvhdescError(
                    f"{where}: includes {target}, which is not a regular file (a FIFO, a device, a folder)"
                )
            return read(*args)

        return guard

    saved = xacro.parse, xacro.load_yaml
    xacro.parse = guarded(saved[0], lambda inp, filename=None: filename if inp is None else None)
    xacro.load_yaml = guarded(saved[1], lambda filename: xacro.abs_filename_spec(filename))
    try:
        yield
    finally:
        xacro.parse, xacro.load_yaml = saved


def validate_file(
    path: Path,
    selected: set[str],
    packages: dict[str, Path],
    walked: bool = False,
    xacro_args: dict[str, str] | None = None,
    tier: str = "static",
    quirks: Quirks | None = None,
) -> FileReport:
    """One file's report. A file given by name that cannot be parsed (or a xacro that does not expand) is an
    SvhdescError; one found in a folder's walk is a report whose xml check fails, so that one broken file does not
    hide the others' findings."""
    started = time.perf_counter()
    try:
        tolerated: list[Finding] = []
        root, xacro_files = _read_robot(path, packages, xacro_args or {}, tolerated)
    except SvhdescError as exc:
        if not walked:
            raise
        where, _, message = str(exc).partition(": ")
        file, _, line = where.rpartition(":") if where.rpartition(":")[2].isdigit() else (where, "", "")
        finding = Finding("xml", file, int(line) if line else None, message)
        return FileReport(str(path), "unknown", [CheckResult("xml", "fail", [finding])], time.perf_counter() - started)
    if root.tag == "robot":
        report = FileReport(str(path), "urdf")
        source = UrdfSource(path, root, _Packages(packages, path), xacro_files)
        report.checks.append(_result("xml", tolerated))
        parsers = Parsers(source, selected)  # external tools run while the rules read the file
        for name, rule in RULES.items():
            if name in selected:
                report.checks.append(_result(name, rule(source)))
        report.checks.extend(parsers.results())
        if tier == "full" and selected & {"mujoco_compile", *FULL_CHECKS}:
            refused = unsimulated(root, path, walked, "mujoco_compile")
            report.checks.extend(refused or _full_urdf(source, quirks or Quirks()))
    elif root.tag == "mujoco":
        report = FileReport(str(path), "mjcf")
        report.checks.append(_result("xml", tolerated))
        refused = unsimulated(root, path, walked, "mjcf_compile") if tier == "full" else None
        report.checks.extend(refused or _mjcf_checks(path, selected, tier, quirks or Quirks()))
    else:
        raise SvhdescError(f"{path}:{root.sourceline}: not a robot file (root <{root.tag}>, not <robot> or <mujoco>)")
    report.checks = [c for c in report.checks if c.name in selected]
    report.seconds = time.perf_counter() - started
    return report


def _mjcf_files(path: Path) -> list[tuple[Path, etree._Element]]:
    """The MJCF and every file it includes, parsed (for the lines of named elements)."""
    out, queue, seen = [], [path], set()
    while queue:
        current = queue.pop()
        if current.resolve() in seen or not current.is_file():
            continue
        seen.add(current.resolve())
        try:
            root = etree.parse(str(current), _parser()).getroot()
        except (etree.XMLSyntaxError, OSError):
            continue
        out.append((current, root))
        queue.extend(current.parent / i.get("file", "") for i in root.iter("include"))
    return out


def _locate(files: list[tuple[Path, etree._Element]], tag: str, name: str) -> tuple[str, int | None]:
    for path, root in files:
        for element in root.iter(tag):
            if element.get("name") == name:
                return str(path), element.sourceline
    return str(files[0][0]) if files else "", None


def _full_urdf(source: UrdfSource, quirks: Quirks) -> list[CheckResult]:
    from svhdesc.validate.compile_file import CompileFailed, compile_urdf

    if quirks.keyframe is not None:
        raise SvhdescError(
            f"{source.path}: the settings name keyframe '{quirks.keyframe}', but a URDF has no keyframes "
            "(its rest pose is the settings' pose = {JOINT = position})"
        )
    try:
        compiled = compile_urdf(source, dict(quirks.pose), quirks.joints)
    except CompileFailed as exc:
        where = exc.file or str(source.path)
        finding = Finding("mujoco_compile", where, exc.line, f"MuJoCo's URDF importer refuses it: {exc}")
        skipped = [CheckResult(n, "skipped", reason="MuJoCo does not open the model") for n in FULL_CHECKS]
        return [CheckResult("mujoco_compile", "fail", [finding]), *skipped]
    compiled_check = CheckResult("mujoco_compile", "pass", figure="; ".join(compiled.notes))
    return [compiled_check, *run_full_checks(compiled)]


_ACTUATOR_TAGS = ("general", "motor", "position", "velocity", "intvelocity", "damper", "cylinder", "muscle")


def _mjcf_where(path: Path, files: list[tuple[Path, etree._Element]]):  # type: ignore[no-untyped-def]
    def where(tag: str, name: str) -> tuple[str, int | None]:
        """tag rating: the actuator driving joint ``name`` (its force bound), else the joint."""
        if tag == "rating":
            for file, root in files:
                for element in root.iterfind("actuator/*"):
                    if element.tag in _ACTUATOR_TAGS and element.get("joint") == name:
                        return str(file), element.sourceline
            tag = "joint"
        if tag == "equality":
            for file, root in files:
                for element in root.iterfind("equality/*"):
                    if name in (element.get("name"), element.get("joint1")):
                        return str(file), element.sourceline
        if tag == "timestep":  # the <option> stating it, else the model's root: where a timestep is set
            stated = [(f, e) for f, root in files for e in root.iterfind("option") if e.get("timestep") is not None]
            file, element = stated[-1] if stated else (path, files[0][1] if files else None)
            return str(file), element.sourceline if element is not None else None
        return _locate(files, tag, name) if tag != "model" else (str(path), None)

    return where


def _irregular_assets(files: list[tuple[Path, etree._Element]]) -> list[Finding]:
    """Asset files (a mesh, texture, height field, skin) that exist and are not regular files, each a finding at
    its element: looked up beside the file that names it and in its compiler's meshdir, texturedir and assetdir."""
    found = []
    for file, root in files:
        folders = [file.parent]
        for compiler in root.iter("compiler"):
            keys = ("assetdir", "meshdir", "texturedir")
            folders += [file.parent / compiler.get(k, "") for k in keys if compiler.get(k)]
        for element in root.iter():
            name = element.get("file") if isinstance(element.tag, str) else None  # an <include> too
            for candidate in (folder / name for folder in folders) if name else ():
                if not os.path.lexists(candidate):
                    continue
                if candidate.is_file():  # a mesh MuJoCo would read for minutes and gigabytes: not compiled either
                    what = mesh_size_problem(candidate) if element.tag == "mesh" else None
                else:
                    what = "a folder" if candidate.is_dir() else "not a regular file"
                if what is not None:
                    message = f'<{element.tag} file="{name}">: {candidate} is {what}'
                    found.append(Finding("mjcf_compile", str(file), element.sourceline, message))
                    break
    return found


def _mjcf_checks(
    path: Path, selected: set[str], tier: str = "static", quirks: Quirks | None = None
) -> list[CheckResult]:
    import mujoco

    quirks = quirks or Quirks()

    from svhdesc.validate.compile_file import quiet_mujoco

    files = _mjcf_files(path)
    irregular = _irregular_assets(files)
    if irregular:  # MuJoCo would open a FIFO and wait forever: named, and nothing compiled
        rest = [
            CheckResult(n, "skipped", reason="the model is not compiled")
            for n in (*STATIC_MJCF_CHECKS[1:], *(FULL_CHECKS if tier == "full" else ()))
        ]
        return [CheckResult("mjcf_compile", "fail", irregular), *rest]
    try:
        with quiet_mujoco() as said:  # MuJoCo's compiler warnings (deprecated attributes) go into the figure
            model = mujoco.MjModel.from_xml_path(str(path))
    except ValueError as exc:
        message = str(exc).strip().splitlines()
        line_match = re.search(r"line (\d+)", str(exc))
        file_match = re.search(r"[Ff]ile '?([^',\s]+\.xml)", str(exc))
        where = file_match.group(1) if file_match else str(path)
        finding = Finding("mjcf_compile", where, int(line_match.group(1)) if line_match else None, " ".join(message))
        rest = [
            CheckResult(n, "skipped", reason="the model does not compile")
            for n in (*STATIC_MJCF_CHECKS[1:], *(FULL_CHECKS if tier == "full" else ()))
        ]
        return [CheckResult("mjcf_compile", "fail", [finding]), *rest]
    warned = "; ".join(" ".join(line.split()) for line in said)
    compiled = CheckResult("mjcf_compile", "pass", figure=warned)
    checks = [compiled, _actuator_ranges(model, files), _keyframes(model, files)]
    if tier == "full" and selected & set(FULL_CHECKS):
        from svhdesc.validate.compile_file import mjcf_compiled

        checks += run_full_checks(mjcf_compiled(model, _mjcf_where(path, files), quirks.keyframe, quirks.joints, path))
    return checks


def _actuator_ranges(model, files) -> CheckResult:  # type: ignore[no-untyped-def]
    """A position actuator's ctrlrange within its joint's range: a target beyond the stop only pushes on it."""

    findings = []
    for i in range(model.nu):
        actuator = model.actuator(i)
        joint = int(model.actuator_trnid[i, 0])
        if not (is_position_servo(model, i) and model.actuator_ctrllimited[i]):
            continue
        if not model.jnt_limited[joint]:
            continue
        lo, hi = model.jnt_range[joint]
        clo, chi = model.actuator_ctrlrange[i]
        slack = ACTUATOR_SLACK * (hi - lo)
        if clo < lo - slack or chi > hi + slack:
            where, line = _locate(files, "position", actuator.name) if actuator.name else (str(files[0][0]), None)
            if line is None and actuator.name:
                where, line = _locate(files, "general", actuator.name)
            findings.append(
                Finding(
                    "actuator_ranges",
                    where,
                    line,
                    f"actuator '{actuator.name or i}': ctrlrange {clo:.6g} .. {chi:.6g} beyond joint "
                    f"'{model.joint(joint).name}' range {lo:.6g} .. {hi:.6g}",
                    f'ctrlrange="{max(clo, lo):.6g} {min(chi, hi):.6g}"',
                )
            )
    if model.nu == 0:
        return CheckResult("actuator_ranges", "skipped", reason="no actuators")
    return _result("actuator_ranges", findings)


def _keyframes(model, files) -> CheckResult:  # type: ignore[no-untyped-def]
    """Every keyframe's joint positions within the joints' limits."""
    if model.nkey == 0:
        return CheckResult("keyframes", "skipped", reason="no keyframes")
    findings = []
    for k in range(model.nkey):
        key = model.key(k)
        for j in np.flatnonzero(model.jnt_limited):
            kind = model.jnt_type[j]
            if kind not in (2, 3):  # slide, hinge: one coordinate each
                continue
            q = float(key.qpos[model.jnt_qposadr[j]])
            lo, hi = model.jnt_range[j]
            if q < lo - KEYFRAME_SLACK or q > hi + KEYFRAME_SLACK:
                where, line = _locate(files, "key", key.name) if key.name else (str(files[0][0]), None)
                findings.append(
                    Finding(
                        "keyframes",
                        where,
                        line,
                        f"keyframe '{key.name or k}': joint '{model.joint(j).name}' at {q:.6g}, "
                        f"outside {lo:.6g} .. {hi:.6g}",
                    )
                )
    return _result("keyframes", findings)
