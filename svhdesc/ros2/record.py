"""``--record FILE.mcap``: the node's messages as ROS 2 CDR in MCAP, the way rosbag2's MCAP storage writes them.

Profile ``ros2``; one schema per message type, encoding ``ros2msg``, whose text is the type's .msg definition
followed by each type it uses (recursively), each after a line of 80 ``=`` and ``MSG: pkg/msg/Type`` (rosbag2's
message_definition_cache); channels with message encoding ``cdr``. Payloads are encoded by mcap-ros2-support
from that definition (rclpy's ``serialize_message`` is not used: with Fast DDS it returns rmw's estimated size,
with trailing bytes that strict readers such as rosbags refuse). Log and publish times are the simulated time in
nanoseconds. The file is written beside FILE as a temporary and renamed onto FILE when the
recording closes, so FILE is either absent or complete.
"""

from __future__ import annotations

import os
import sys
import tempfile
from pathlib import Path
from typing import Any

from svhdesc.errors import SvhdescError

SEPARATOR = "=" * 80
PRIMITIVES = {
    "bool",
    "byte",
    "char",
    "float32",
    "float64",
    "int8",
    "uint8",
    "int16",
    "uint16",
    "int32",
    "uint32",
    "int64",
    "uint64",
    "string",
    "wstring",
}


def _share_dirs() -> list[Path]:
    """Where ament packages' share/ folders are: AMENT_PREFIX_PATH, then this venv (the wheels install there)."""
    prefixes = [p for p in os.environ.get("AMENT_PREFIX_PATH", "").split(os.pathsep) if p]
    return [Path(p) / "share" for p in [*prefixes, sys.prefix]]


def _definition_file(package: str, name: str) -> Path:
    for share in _share_dirs():
        path = share / package / "msg" / f"{name}.msg"
        if path.is_file():
            return path
    raise SvhdescError(f"--record: no definition of {package}/msg/{name} under {', '.join(map(str, _share_dirs()))}")


def _uses(package: str, text: str) -> list[tuple[str, str]]:
    """The message types a .msg text names, as (package, name), in order of first use."""
    found: list[tuple[str, str]] = []
    for line in text.splitlines():
        code = line.split("#", 1)[0].strip()
        if not code or _is_constant(code):
            continue
        base = code.split()[0].split("[")[0].split("<=")[0]
        if base in PRIMITIVES:
            continue
        parts = base.split("/")
        used = (parts[0], parts[-1]) if len(parts) > 1 else (package, parts[0])
        if used not in found:
            found.append(used)
    return found


def _is_constant(code: str) -> bool:
    """``int32 STRICT=2``: a constant, not a field (a field's default value has no '=')."""
    words = code.split(None, 1)
    return len(words) == 2 and "=" in words[1]


def message_definition(full_type: str) -> str:
    """rosbag2's ``ros2msg`` schema text of ``pkg/msg/Type``."""
    package, _, name = full_type.split("/")
    text = _definition_file(package, name).read_text()
    parts = [text.rstrip("\n")]
    seen = {(package, name)}
    pending = _uses(package, text)
    while pending:
        used = pending.pop(0)
        if used in seen:
            continue
        seen.add(used)
        body = _definition_file(*used).read_text()
        parts.append(f"{SEPARATOR}\nMSG: {used[0]}/msg/{used[1]}\n{body.rstrip(chr(10))}")
        pending.extend(u for u in _uses(used[0], body) if u not in seen)
    return "\n".join(parts) + "\n"


def type_name(message: Any) -> str:
    """``sensor_msgs/msg/JointState`` of an rclpy message."""
    cls = type(message)
    return f"{cls.__module__.split('.')[0]}/msg/{cls.__name__}"


class Recorder:
    def __init__(self, path: Path) -> None:
        try:
            from mcap_ros2.writer import Writer
        except ImportError as exc:
            raise SvhdescError(f"--record needs the ros2 extra's mcap-ros2-support ({exc}): use .venv-ros2") from None
        self.path = path
        if path.suffix != ".mcap":
            raise SvhdescError(f"--record: {path} should end in .mcap (rosbag2's MCAP storage)")
        if not path.parent.is_dir():
            raise SvhdescError(f"--record: folder {path.parent} does not exist")
        handle, temporary = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".part", dir=path.parent)
        self._temporary = Path(temporary)
        mask = os.umask(0)
        os.umask(mask)
        os.chmod(handle, 0o666 & ~mask)  # mkstemp's 0600 would make the recording private
        self._stream = os.fdopen(handle, "wb")
        self._writer = Writer(self._stream)  # profile ros2, zstd chunks
        self._schemas: dict[str, Any] = {}
        self._sequence = 0
        self.count = 0

    def write(self, topic: str, message: Any, at: float) -> None:
        """``message`` on ``topic`` at simulated time ``at`` (s)."""
        nanoseconds = int(round(at * 1e9))
        kind = type_name(message)
        schema = self._schemas.get(kind)
        if schema is None:
            schema = self._schemas[kind] = self._writer.register_msgdef(kind, message_definition(kind))
        self._sequence += 1
        self._writer.write_message(topic, schema, message, nanoseconds, nanoseconds, self._sequence)
        self.count += 1

    def close(self, keep: bool = True) -> None:
        """Finish the file and rename it onto the target (or, ``keep`` False, delete it)."""
        try:
            self._writer.finish()
            self._stream.close()
            if keep:
                os.replace(self._temporary, self.path)
        finally:
            if self._temporary.exists():
                self._temporary.unlink()
