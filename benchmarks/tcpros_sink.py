"""A minimal TCPROS subscriber for the node benchmark: it subscribes to every topic a node publishes and reads the
bytes without deserialising them (only /clock is parsed, to measure simulated time).

The node under test serialises and sends every message to a real TCP subscriber, exactly as to rospy's; only the
subscriber side is cheap, so that on a 2-core machine the benchmark's own receiving does not take the node's CPU.
(rospy's AnyMsg subscribers still run a Python thread and a callback per message: tens of microseconds each, at
thousands of messages a wall second.) Protocol: ROS 1's TCPROS (a length-prefixed connection header with
callerid, topic and md5sum ``*``, then length-prefixed messages); the publisher is found through the master's and
the node's XML-RPC APIs (lookupNode, requestTopic), as rospy finds it.
"""

from __future__ import annotations

import selectors
import socket
import struct
import threading
from collections.abc import Sequence
from xmlrpc.client import ServerProxy

CALLER = "/svhdesc_bench_sink"


def _header(fields: dict[str, str]) -> bytes:
    body = b"".join(struct.pack("<I", len(f)) + f for f in (f"{k}={v}".encode() for k, v in fields.items()))
    return struct.pack("<I", len(body)) + body


def _read_exactly(sock: socket.socket, size: int) -> bytes:
    data = b""
    while len(data) < size:
        chunk = sock.recv(size - len(data))
        if not chunk:
            raise ConnectionError("the publisher closed the connection during the handshake")
        data += chunk
    return data


def _handshake(sock: socket.socket, topic: str) -> None:
    # tcp_nodelay not asked for: the default of rospy's and roscpp's subscribers
    sock.sendall(_header({"callerid": CALLER, "topic": topic, "md5sum": "*"}))
    (size,) = struct.unpack("<I", _read_exactly(sock, 4))
    body, fields = _read_exactly(sock, size), {}
    while body:
        (length,) = struct.unpack("<I", body[:4])
        key, _, value = body[4 : 4 + length].decode().partition("=")
        fields[key] = value
        body = body[4 + length :]
    if "error" in fields:
        raise ConnectionError(f"{topic}: {fields['error']}")


class Sink:
    """Subscribes to ``node``'s published topics (all of them, or those named) and discards what comes."""

    def __init__(self, master_uri: str, node: str) -> None:
        self._master = ServerProxy(master_uri)
        code, message, api = self._master.lookupNode(CALLER, node)
        if code != 1:
            raise ConnectionError(f"master: {message}")
        self._node, self._name = ServerProxy(api), node
        self._selector = selectors.DefaultSelector()
        self._topics: set[str] = set()
        self._clock = b""
        self.clock = 0.0  # the latest /clock, simulated seconds
        self.received = 0  # bytes read in all
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name="tcpros-sink", daemon=True)
        self._thread.start()

    def published(self) -> list[str]:
        _, _, (publishers, _, _) = self._master.getSystemState(CALLER)
        return sorted(topic for topic, nodes in publishers if self._name in nodes)

    def subscribe_all(self, only: Sequence[str] | None = None) -> int:
        """Subscribe to every topic the node publishes (or those of them in ``only``) not yet subscribed; returns
        how many are subscribed."""
        for topic in self.published():
            if topic not in self._topics and (only is None or topic in only):
                code, message, protocol = self._node.requestTopic(CALLER, topic, [["TCPROS"]])
                if code != 1:
                    raise ConnectionError(f"{topic}: {message}")
                _, host, port = protocol
                sock = socket.create_connection((host, port), timeout=10)
                _handshake(sock, topic)
                sock.setblocking(False)
                self._selector.register(sock, selectors.EVENT_READ, topic)
                self._topics.add(topic)
        return len(self._topics)

    def _run(self) -> None:
        buffer = bytearray(1 << 16)
        while not self._stop.is_set():
            if not self._topics:
                self._stop.wait(0.01)
                continue
            for key, _ in self._selector.select(0.1):
                try:
                    size = key.fileobj.recv_into(buffer)  # type: ignore[union-attr]
                except (BlockingIOError, InterruptedError):
                    continue
                except OSError:
                    size = 0
                if not size:
                    self._selector.unregister(key.fileobj)
                    continue
                self.received += size
                if key.data == "/clock":
                    self._read_clock(bytes(buffer[:size]))

    def _read_clock(self, data: bytes) -> None:
        """rosgraph_msgs/Clock messages: uint32 length (8), uint32 secs, uint32 nsecs."""
        self._clock += data
        while len(self._clock) >= 12:
            (length,) = struct.unpack_from("<I", self._clock)
            if len(self._clock) < 4 + length:
                break
            secs, nsecs = struct.unpack_from("<II", self._clock, 4)
            self.clock = secs + 1e-9 * nsecs
            self._clock = self._clock[4 + length :]

    def close(self) -> None:
        self._stop.set()
        self._thread.join(2.0)
        for key in list(self._selector.get_map().values()):
            key.fileobj.close()  # type: ignore[union-attr]
        self._selector.close()
