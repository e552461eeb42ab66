"""Check 3: the URDF as real consumers read it: urdfdom (check_urdf), yourdfpy, and sdformat (ign sdf)."""

from __future__ import annotations

import logging
import resource
import shutil
import subprocess
import tempfile
from pathlib import Path

from lxml import etree

from svhdesc.model import Model
from svhdesc.validate.options import Options
from svhdesc.validate.pair import ModelPair
from svhdesc.validate.report import Check, not_run, verdict

URDFDOM_INSTALL = "apt-get install liburdfdom-tools"
# ignition-tools gives the `ign` front end; libsdformat-dev brings the `sdf` subcommand (sdformat12.yaml and
# cmdsdformat12.rb) and libsdformat12; ruby comes with ignition-tools.
SDFORMAT_INSTALL = "apt-get install ignition-tools libsdformat-dev"
TIMEOUT = 120  # s per external command
# Address space an external tool may take: `ign sdf` on a 10,000-link chain grew past 8 GB in 35 s.
MEMORY_LIMIT = 4 << 30


def _limit_memory() -> None:  # in the child, before it starts the tool
    resource.setrlimit(resource.RLIMIT_AS, (MEMORY_LIMIT, MEMORY_LIMIT))


def _run(args: list[str], cwd: Path) -> subprocess.CompletedProcess[str]:
    """The tool's result; over TIMEOUT or MEMORY_LIMIT a failed one whose stderr names the limit."""
    try:
        result = subprocess.run(
            args, cwd=cwd, capture_output=True, text=True, timeout=TIMEOUT, check=False, preexec_fn=_limit_memory
        )
    except subprocess.TimeoutExpired:
        return subprocess.CompletedProcess(args, -9, "", f"stopped at the time limit of {TIMEOUT} s")
    if result.returncode != 0 and any(
        word in result.stderr for word in ("bad_alloc", "MemoryError", "NoMemoryError", "Cannot allocate memory")
    ):
        result.stderr += f"\nout of memory at the limit of {MEMORY_LIMIT >> 30} GiB of address space"
    return result


def _tail(text: str, lines: int = 3) -> str:
    # ign prints a harmless banner about an optional backtrace library on every call.
    kept = [line.strip() for line in text.splitlines() if line.strip() and "libignition-tools-backward" not in line]
    return " | ".join(kept[-lines:])


def _local_mesh(uri: str, base: Path) -> Path | None:
    """A mesh URI as a local path: the model's own package://, file://, paths (None for other schemes)."""
    return Model(base.name, base).mesh_file(uri)


def check_urdfdom(pair: ModelPair, options: Options) -> list[Check]:
    bound = "check_urdf exit 0"
    tool = shutil.which("check_urdf")
    if tool is None:
        return [
            not_run(
                "urdfdom", f"check_urdf not found; install with: {URDFDOM_INSTALL}", bound, missing_tool=URDFDOM_INSTALL
            )
        ]
    result = _run([tool, str(pair.urdf_path.resolve())], pair.urdf_path.parent)
    ok = result.returncode == 0 and "Successfully Parsed XML" in result.stdout
    root = next(
        (line.split(":", 1)[1].split()[0] for line in result.stdout.splitlines() if line.startswith("root Link:")), "?"
    )
    detail = f"root link {root}" if ok else _tail(result.stderr + result.stdout)
    return [
        Check(
            "urdfdom",
            verdict(ok),
            f"exit {result.returncode}",
            bound,
            detail,
            {"returncode": result.returncode, "root": root},
        )
    ]


class _Collect(logging.Handler):
    def __init__(self) -> None:
        super().__init__(logging.WARNING)
        self.messages: list[str] = []

    def emit(self, record: logging.LogRecord) -> None:
        self.messages.append(record.getMessage())


def check_yourdfpy(pair: ModelPair, options: Options) -> list[Check]:
    bound = "loads, validate() true, all links/joints, meshes exist"
    try:
        import yourdfpy
    except ImportError:
        return [
            not_run(
                "yourdfpy",
                "yourdfpy is not installed (pip install yourdfpy)",
                bound,
                missing_tool="pip install yourdfpy",
            )
        ]
    collector = _Collect()
    logger = logging.getLogger("yourdfpy")
    logger.addHandler(collector)
    try:
        robot = yourdfpy.URDF.load(str(pair.urdf_path), load_meshes=False, build_collision_scene_graph=False)
        valid = bool(robot.validate())
    except Exception as exc:  # any parser failure is the finding itself
        return [Check("yourdfpy", "fail", "load failed", bound, f"{type(exc).__name__}: {exc}")]
    finally:
        logger.removeHandler(collector)
    problems = [f"validate(): {m}" for m in collector.messages] if not valid else []
    facts = pair.urdf
    if facts is not None:
        if len(robot.link_map) != len(facts.links) or len(robot.joint_map) != len(facts.joints):
            problems.append(
                f"yourdfpy sees {len(robot.link_map)} links / {len(robot.joint_map)} joints, the file "
                f"has {len(facts.links)} / {len(facts.joints)}"
            )
        missing = []
        for uri in facts.meshes:
            path = _local_mesh(uri, pair.urdf_path.parent)
            if path is not None and not path.is_file():
                missing.append(uri)
        if missing:
            problems.append(f"{len(missing)} mesh file(s) missing, e.g. {missing[0]}")
    measured = f"{len(robot.link_map)} links, {len(robot.actuated_joint_names)} actuated"
    detail = (
        "; ".join(problems)
        or f"{len(robot.joint_map)} joints, mimic joints: "
        f"{sum(1 for j in robot.joint_map.values() if j.mimic is not None)}"
    )
    return [
        Check(
            "yourdfpy",
            verdict(not problems),
            measured,
            bound,
            detail,
            {
                "links": len(robot.link_map),
                "joints": len(robot.joint_map),
                "actuated": list(robot.actuated_joint_names),
                "problems": problems,
            },
        )
    ]


def _sdf_available(tool: str) -> bool:
    try:
        result = subprocess.run([tool, "sdf", "--help"], capture_output=True, text=True, timeout=TIMEOUT, check=False)
    except OSError:
        return False
    return result.returncode == 0 and "cannot find any available" not in result.stdout + result.stderr


def check_sdformat(pair: ModelPair, options: Options) -> list[Check]:
    bound = "converts, ign sdf -k valid, no joint dropped"
    tool = shutil.which("ign")
    if tool is None or not _sdf_available(tool):
        what = "ign not found" if tool is None else "ign has no 'sdf' subcommand"
        return [not_run("sdformat", f"{what}; install with: {SDFORMAT_INSTALL}", bound, missing_tool=SDFORMAT_INSTALL)]
    base = pair.urdf_path.parent.resolve()
    # ign turns package://NAME/... into model://NAME/..., which Gazebo finds on its resource path (the folder that
    # holds the package): checked below against the model's own package.
    converted = _run([tool, "sdf", "-p", str(pair.urdf_path.resolve())], base)
    if converted.returncode != 0 or not converted.stdout.strip():
        return [
            Check(
                "sdformat",
                "fail",
                f"conversion exit {converted.returncode}",
                bound,
                _tail(converted.stderr + converted.stdout),
            )
        ]
    with tempfile.TemporaryDirectory(prefix="svhdesc-sdf-") as tmp:
        sdf_path = Path(tmp) / f"{pair.name}.sdf"
        sdf_path.write_text(converted.stdout)
        checked = _run([tool, "sdf", "-k", str(sdf_path)], base)
    valid = checked.returncode == 0 and "Valid" in checked.stdout
    problems = [] if valid else [f"ign sdf -k: {_tail(checked.stderr + checked.stdout)}"]
    try:
        sdf = etree.fromstring(converted.stdout.encode())
    except etree.XMLSyntaxError as exc:
        return [Check("sdformat", "fail", "unparsable output", bound, str(exc))]
    sdf_joints = {j.get("name") for j in sdf.iter("joint") if j.get("type") not in (None, "fixed")}
    dropped = _dropped_joints(pair, sdf_joints, problems)
    uris = [u.text.strip() for u in sdf.iter("uri") if u.text]
    unresolved = _unresolved_uris(uris, base, problems)
    links = sum(1 for _ in sdf.iter("link"))
    measured = f"{links} links, {len(sdf_joints)} movable joints"
    detail = "; ".join(problems) or f"valid; all {len(uris)} mesh URIs resolve"
    return [
        Check(
            "sdformat",
            verdict(not problems),
            measured,
            bound,
            detail,
            {
                "sdf_links": links,
                "sdf_movable_joints": sorted(sdf_joints),
                "dropped_joints": dropped,
                "unresolved_uris": unresolved,
            },
        )
    ]


def _dropped_joints(pair: ModelPair, sdf_joints: set[str], problems: list[str]) -> list[str]:
    """The URDF's movable joints the SDFormat lacks (a problem naming them and why, appended to `problems`)."""
    facts = pair.urdf
    if facts is None:
        return []
    dropped = [name for name, j in facts.joints.items() if j.movable and name not in sdf_joints]
    if dropped:
        problems.append(
            f"{len(dropped)} of {sum(j.movable for j in facts.joints.values())} movable joints "
            f"dropped ({', '.join(dropped[:4])}{', ...' if len(dropped) > 4 else ''}); "
            f"{_massless_cause(pair, dropped)}"
        )
    return dropped


def _unresolved_uris(uris: list[str], base: Path, problems: list[str]) -> list[str]:
    """The mesh URIs that name a missing file; those and the URIs in a scheme nothing resolves are problems
    (appended to `problems`)."""
    unresolved = [u for u in uris if (p := _local_mesh(u, base)) is not None and not p.is_file()]
    if unresolved:
        problems.append(f"{len(unresolved)} mesh URI(s) do not resolve, e.g. {unresolved[0]}")
    unknown = sum(1 for u in uris if _local_mesh(u, base) is None)
    if unknown:
        problems.append(f"{unknown} mesh URI(s) in a scheme nothing here resolves")
    return unresolved


def _massless_cause(pair: ModelPair, dropped: list[str]) -> str:
    """sdformat drops a movable joint whose parent link has no <inertial> (and everything below it);
    adding an inertial to exactly those parents brings the joints back."""
    facts = pair.urdf
    assert facts is not None
    culprits: list[str] = []
    for name in dropped:
        parent = facts.joints[name].parent
        if facts.links.get(parent) is None and parent not in culprits:
            culprits.append(parent)
    if not culprits:
        return "the rest hang below them"
    return f"parent links without <inertial>: {', '.join(culprits)} (the rest hang below them)"
