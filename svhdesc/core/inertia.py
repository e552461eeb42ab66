"""What makes a rigid body's inertial unphysical: the one rule the config's explicit inertials and the source's are
both held to."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np


def inertial_problem(mass: float, inertia: Sequence[float]) -> str | None:
    """A mass <= 0, a tensor (ixx, ixy, ixz, iyy, iyz, izz) not positive definite, or principal moments that violate
    the triangle inequality; None for a valid inertial."""
    ixx, ixy, ixz, iyy, iyz, izz = inertia
    tensor = np.array([[ixx, ixy, ixz], [ixy, iyy, iyz], [ixz, iyz, izz]], dtype=float)
    moments = np.linalg.eigvalsh(tensor)
    if mass <= 0 or moments[0] <= 0:
        return f"inertia not positive definite (mass {mass}, moments {moments})"
    a, b, c = moments
    if a + b < c * (1 - 1e-9):
        return f"principal moments {moments} violate the triangle inequality"
    return None
