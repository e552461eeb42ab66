"""`svhdesc validate PATH` runs on a pull request's files: hostile robot files, as it runs in CI (a process of its
own, here bounded by 60 s and 4 GiB of address space), each answered as promised and none able to make it read a
file outside the model's folder.

Seeded faults, each failing its case: the parser with entities resolved (the external entity's file outside the
model's folder is read into the document; the billion laughs expand); ``_irregular_assets`` not called (the MJCF's
FIFO mesh blocks MuJoCo's open until the limit); ``path.is_file()`` dropped from the full tier's mesh preparation
(the URDF's FIFO mesh blocks); ``_regular`` not called (the FIFO given by name blocks the read).

The audit hook sees the opens Python makes (trimesh, xacro, the cache); libxml2's and MuJoCo's own opens happen in
C, which it cannot see: the entities are checked in the parsed document instead.
"""

from __future__ import annotations

import json
import os
import resource
import subprocess
import sys
import time
from pathlib import Path

import pytest
from lxml import etree

from svhdesc.errors import SvhdescError
from svhdesc.validate.files import read_xml

ARM = """<?xml version="1.0"?>
{doctype}<robot name="arm">
  <link name="base"/>
  <link name="{link}"><inertial><mass value="{mass}"/>
    <inertia ixx="0.01" iyy="0.01" izz="0.01" ixy="0" ixz="0" iyz="0"/></inertial>{collision}</link>
  <joint name="j" type="revolute"><parent link="base"/><child link="{link}"/><axis xyz="0 1 0"/>
    <limit lower="-1" upper="1" effort="10" velocity="1"/></joint>
</robot>
"""
SECRET = "TOP-SECRET-5c1e"
MESH = '<collision><geometry><mesh filename="meshes/part.stl"/></geometry></collision>'


def _arm(doctype: str = "", link: str = "upper", mass: str = "1", collision: str = "") -> str:
    return ARM.format(doctype=doctype, link=link, mass=mass, collision=collision)


def _limits() -> None:
    resource.setrlimit(resource.RLIMIT_AS, (4 << 30, 4 << 30))


def _validate(*args: str) -> tuple[int, str, str, float]:
    started = time.perf_counter()
    done = subprocess.run(
        [sys.executable, "-m", "svhdesc.cli", "validate", *args],
        capture_output=True,
        text=True,
        timeout=60,
        preexec_fn=_limits,
    )
    return done.returncode, done.stdout, done.stderr, time.perf_counter() - started


def _hostile_files(root: Path) -> dict[str, tuple[Path, str]]:
    """name -> (the file, what the answer must say)."""
    root.mkdir()
    laughs = (
        "<!DOCTYPE robot [\n"
        + "\n".join(
            [
                '<!ENTITY l0 "ha">',
                *(f'<!ENTITY l{i} "{("&l" + str(i - 1) + ";") * 10}">' for i in range(1, 10)),
            ]
        )
        + "\n]>\n"
    )
    secret = root.parent / "secret.txt"  # outside the model's folder
    secret.write_text(SECRET)
    xxe = f'<!DOCTYPE robot [<!ENTITY secret SYSTEM "file://{secret}">]>\n'
    files = {
        "billion_laughs": (_arm(laughs, link="&l9;"), ""),
        "external_entity": (_arm(xxe).replace('<link name="base"/>', '<link name="base">&secret;</link>'), ""),
        "deep_nesting": ("<robot>" + "<link>" * 100_000 + "</link>" * 100_000 + "</robot>", "not well-formed XML"),
        "huge_number": (_arm(mass="1e999"), "not a finite number"),
        "not_xml": ("\x00\x01binary\xff", "not well-formed XML"),
    }
    found = {}
    for name, (text, words) in files.items():
        path = root / f"{name}.urdf"
        path.write_text(text, errors="surrogateescape")
        found[name] = (path, words)
    fifo = root / "pipe.urdf"
    os.mkfifo(fifo)
    found["fifo"] = (fifo, "not a regular file")
    loop = root / "loop.urdf"
    loop.symlink_to(root / "loop2.urdf")
    (root / "loop2.urdf").symlink_to(loop)
    found["symlink_loop"] = (loop, "symbolic links")
    return found


@pytest.mark.parametrize(
    "name", ["billion_laughs", "external_entity", "deep_nesting", "huge_number", "not_xml", "fifo", "symlink_loop"]
)
def test_hostile_urdf_files_are_answered_in_bounds(tmp_path: Path, name: str) -> None:
    path, words = _hostile_files(tmp_path / "repo")[name]
    code, out, err, seconds = _validate(str(path), "--format", "json")
    assert seconds < 60 and "Traceback" not in err, err
    if words == "not a finite number":  # a finding, not a refusal
        assert code == 1 and words in out
    elif words:
        assert code == 2 and err.startswith("error:") and err.count("\n") == 1 and words in err, err
    else:  # entities are not expanded: the file is read as written, without the entity's text
        assert code in (0, 1, 2) and "ha" * 10 not in out + err and SECRET not in out + err
        try:  # the document validate checks, in this process (or refused: libxml2 caps the amplification)
            tree = etree.tostring(read_xml(path))
        except SvhdescError:
            tree = b""
        assert SECRET.encode() not in tree and b"ha" * 10 not in tree, "an entity was expanded"


def test_fifo_meshes_do_not_block_the_full_tier(tmp_path: Path) -> None:
    (tmp_path / "meshes").mkdir()
    os.mkfifo(tmp_path / "meshes" / "part.stl")
    urdf = tmp_path / "arm.urdf"
    urdf.write_text(_arm(collision=MESH))
    code, out, err, seconds = _validate(str(urdf), "--format", "json")
    (report,) = json.loads(out)
    meshes = next(c for c in report["checks"] if c["name"] == "meshes")
    assert code == 1 and "not a regular file" in meshes["findings"][0]["message"], err
    mjcf = tmp_path / "arm.xml"
    mjcf.write_text(
        '<mujoco><asset><mesh name="m" file="meshes/part.stl"/></asset><worldbody><body><freejoint/>'
        '<geom type="mesh" mesh="m"/></body></worldbody></mujoco>'
    )
    code, out, err, _ = _validate(str(mjcf), "--format", "json")
    (report,) = json.loads(out)
    compiled = next(c for c in report["checks"] if c["name"] == "mjcf_compile")
    assert code == 1 and compiled["status"] == "fail" and "not a regular file" in compiled["findings"][0]["message"]
    assert compiled["findings"][0]["line"] == 1


AUDIT = """
import sys, json
from pathlib import Path
from svhdesc.validate.files import known_checks, robot_files, validate_file
model, allowed = Path(sys.argv[1]), [Path(p).resolve() for p in sys.argv[2:]]
warm = model / "warm.urdf"  # lazy imports and caches first: what is opened after is what the files ask for
validate_file(warm, set(known_checks()), {}, False, {}, "full")
opened = []
def hook(event, args):
    if event == "open" and isinstance(args[0], (str, bytes)):
        opened.append(str(args[0], "utf-8", "replace") if isinstance(args[0], bytes) else args[0])
sys.addaudithook(hook)
for path, walked in robot_files([model]):
    try:
        validate_file(path, set(known_checks()), {}, walked, {}, "full")
    except Exception as exc:
        pass
outside = [p for p in opened if not any(Path(p).resolve().is_relative_to(a) for a in allowed)]
print(json.dumps(outside))
"""


def test_no_file_outside_the_models_folder_is_opened(tmp_path: Path) -> None:
    """An audit hook (sys.addaudithook) in the validating process records every file opened while the hostile
    folder is validated: each lies in the model's folder or the mesh cache, never /etc (the external entity)."""
    repo = tmp_path / "repo"
    _hostile_files(repo)
    for fifo in ("pipe.urdf", "loop.urdf", "loop2.urdf"):
        (repo / fifo).unlink()  # a folder walk skips them anyway; they would only make the hook's list longer
    (repo / "warm.urdf").write_text(_arm())
    cache = tmp_path / "cache"
    done = subprocess.run(
        [sys.executable, "-c", AUDIT, str(repo), str(repo), str(cache), "/dev", "/proc"],
        capture_output=True,
        text=True,
        timeout=120,
        preexec_fn=_limits,
        env={**os.environ, "XDG_CACHE_HOME": str(cache)},
    )
    assert done.returncode == 0, done.stderr
    assert json.loads(done.stdout.splitlines()[-1]) == []
