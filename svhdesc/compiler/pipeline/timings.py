"""Wall time per build stage, for ``svhdesc build --timings``."""

from __future__ import annotations

import time
from collections.abc import Iterator
from contextlib import contextmanager


class Timings:
    def __init__(self) -> None:
        self.seconds: dict[str, float] = {}

    @contextmanager
    def stage(self, name: str) -> Iterator[None]:
        start = time.perf_counter()
        try:
            yield
        finally:
            self.seconds[name] = self.seconds.get(name, 0.0) + time.perf_counter() - start

    def report(self) -> str:
        total = sum(self.seconds.values())
        lines = [f"  {name:<14} {seconds:8.3f} s" for name, seconds in self.seconds.items()]
        return "\n".join(["timings:", *lines, f"  {'total':<14} {total:8.3f} s"])
