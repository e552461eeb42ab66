"""Arithmetic whose result does not depend on the CPU: what every number written into a model goes through.

numpy picks SIMD kernels per CPU (its sin/cos on AVX-512 differ in the last bit from the baseline ones), and
OpenBLAS/LAPACK pick per-CPU kernels for matmul and eigh, so the same build wrote different last digits on
different machines. Here: IEEE-754 basic operations element by element (exactly rounded, so SIMD or not gives the
same bits), exactly rounded sums (math.fsum, independent of order), the C library's scalar trigonometry, and a
Jacobi eigensolver in plain Python. No BLAS, no LAPACK, no vectorised transcendental functions.

``SVHDESC_PERTURB_ULPS=k`` (a test hook) moves every sum here and the authoring script's circle points by a few
ulps, to show that ``build --check`` tolerates what another CPU could change and nothing more.
"""

from __future__ import annotations

import math
import os
from collections.abc import Sequence

import numpy as np

PERTURB_ENV = "SVHDESC_PERTURB_ULPS"


def perturb_ulps() -> int:
    """The test hook's perturbation in ulps (0 unless the environment sets it)."""
    value = os.environ.get(PERTURB_ENV, "").strip()
    return int(value) if value.lstrip("-").isdigit() else 0


def perturbed(values: np.ndarray) -> np.ndarray:
    """``values`` scaled by 1 +- k ulps, alternating in sign (identity unless the hook is set)."""
    k = perturb_ulps()
    if k == 0:
        return values
    signs = np.where(np.arange(values.size).reshape(values.shape) % 2 == 0, 1.0, -1.0)
    return values * (1.0 + signs * k * np.finfo(np.float64).eps)


def fsum(values: np.ndarray) -> float:
    """Exactly rounded sum: the same bits in any order on any CPU (moved by the test hook's ulps, zero stays zero)."""
    return float(perturbed(np.array(math.fsum(np.asarray(values, dtype=np.float64).tolist()))))


def matmul(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``a @ b`` for small inner dimensions without BLAS: products summed in index order."""
    a, b = np.asarray(a, dtype=np.float64), np.asarray(b, dtype=np.float64)
    result = a[..., :, 0:1] * b[..., 0:1, :]
    for k in range(1, a.shape[-1]):
        result = result + a[..., :, k : k + 1] * b[..., k : k + 1, :]
    return result


def norm(vector: Sequence[float]) -> float:
    return math.sqrt(math.fsum(float(v) * float(v) for v in vector))


def mass_properties(vertices: np.ndarray, faces: np.ndarray) -> tuple[float, np.ndarray, np.ndarray]:
    """(volume, centroid, inertia tensor about the centroid at unit density) of a closed triangle mesh.

    The polyhedral integrals of Eberly ("Polyhedral Mass Properties", 2002), per triangle element-wise, each
    integral summed exactly. Vertices are taken relative to their mean first, which keeps the parallel-axis
    shift small.
    """
    points = np.asarray(vertices, dtype=np.float64)
    origin = np.array([math.fsum(points[:, k].tolist()) / len(points) for k in range(3)])
    tri = (points - origin)[np.asarray(faces, dtype=np.int64)]
    p0, p1, p2 = tri[:, 0], tri[:, 1], tri[:, 2]
    d = np.cross(p1 - p0, p2 - p0)  # element-wise products and differences only
    t0 = p0 + p1
    f1 = t0 + p2
    t1 = p0 * p0
    t2 = t1 + p1 * t0
    f2 = t2 + p2 * f1
    f3 = p0 * t1 + p1 * t2 + p2 * f2
    g0, g1, g2 = f2 + p0 * (f1 + p0), f2 + p1 * (f1 + p1), f2 + p2 * (f1 + p2)
    x, y, z = 0, 1, 2
    volume = fsum(d[:, x] * f1[:, x]) / 6.0
    first = np.array([fsum(d[:, k] * f2[:, k]) for k in range(3)]) / 24.0
    second = np.array([fsum(d[:, k] * f3[:, k]) for k in range(3)]) / 60.0
    mixed = (
        np.array(
            [
                fsum(d[:, x] * (p0[:, y] * g0[:, x] + p1[:, y] * g1[:, x] + p2[:, y] * g2[:, x])),
                fsum(d[:, y] * (p0[:, z] * g0[:, y] + p1[:, z] * g1[:, y] + p2[:, z] * g2[:, y])),
                fsum(d[:, z] * (p0[:, x] * g0[:, z] + p1[:, x] * g1[:, z] + p2[:, x] * g2[:, z])),
            ]
        )
        / 120.0
    )
    c = first / volume
    xx = second[y] + second[z] - volume * (c[y] * c[y] + c[z] * c[z])
    yy = second[z] + second[x] - volume * (c[z] * c[z] + c[x] * c[x])
    zz = second[x] + second[y] - volume * (c[x] * c[x] + c[y] * c[y])
    xy = -(mixed[x] - volume * c[x] * c[y])
    yz = -(mixed[y] - volume * c[y] * c[z])
    zx = -(mixed[z] - volume * c[z] * c[x])
    inertia = np.array([[xx, xy, zx], [xy, yy, yz], [zx, yz, zz]])
    return float(volume), c + origin, inertia


def eigh3(matrix: np.ndarray, sweeps: int = 64) -> tuple[np.ndarray, np.ndarray]:
    """Eigenvalues (ascending) and unit eigenvectors (columns) of a symmetric 3x3 matrix, cyclic Jacobi."""
    a = [[float(matrix[i][j]) for j in range(3)] for i in range(3)]
    v = [[1.0 if i == j else 0.0 for j in range(3)] for i in range(3)]
    for _ in range(sweeps):
        if abs(a[0][1]) + abs(a[0][2]) + abs(a[1][2]) == 0.0:
            break
        for p, q in ((0, 1), (0, 2), (1, 2)):
            if abs(a[p][q]) <= 1e-18 * (abs(a[p][p]) + abs(a[q][q])):
                a[p][q] = a[q][p] = 0.0  # below any digit written: converged
                continue
            theta = (a[q][q] - a[p][p]) / (2.0 * a[p][q])
            t = math.copysign(1.0, theta) / (abs(theta) + math.sqrt(theta * theta + 1.0))
            cos = 1.0 / math.sqrt(t * t + 1.0)
            sin = t * cos
            for k in range(3):  # A <- A J on columns p, q
                akp, akq = a[k][p], a[k][q]
                a[k][p], a[k][q] = cos * akp - sin * akq, sin * akp + cos * akq
            for k in range(3):  # A <- J^T A on rows p, q
                apk, aqk = a[p][k], a[q][k]
                a[p][k], a[q][k] = cos * apk - sin * aqk, sin * apk + cos * aqk
            for k in range(3):
                vkp, vkq = v[k][p], v[k][q]
                v[k][p], v[k][q] = cos * vkp - sin * vkq, sin * vkp + cos * vkq
    order = sorted(range(3), key=lambda i: (a[i][i], i))
    values = np.array([a[i][i] for i in order])
    vectors = np.array([[v[k][i] for i in order] for k in range(3)])
    return values, vectors
