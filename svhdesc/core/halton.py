"""The Halton sequence: poses spread over a robot's joint ranges, the same on any machine (no random generator)."""

from __future__ import annotations

import numpy as np

_PRIMES = (2, 3, 5, 7, 11, 13, 17, 19, 23, 29, 31, 37, 41, 43, 47, 53, 59, 61, 67, 71, 73, 79, 83, 89, 97)


def halton(index: int, dimensions: int) -> np.ndarray:
    """Point ``index`` (from 1) of the Halton sequence in [0, 1)^dimensions; past 25 dimensions the bases repeat,
    shifted, which keeps the points spread enough to sample poses."""
    point = np.empty(dimensions)
    for d in range(dimensions):
        base, i, f, value = _PRIMES[d % len(_PRIMES)], index + d // len(_PRIMES), 1.0, 0.0
        while i > 0:
            f /= base
            value += f * (i % base)
            i //= base
        point[d] = value
    return point
