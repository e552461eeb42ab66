"""Author the svhdesc source meshes procedurally from primitives.

Run as ``python tools/author_meshes.py``.  Writes one COLLADA file per link:

* ``meshes/svh/<link>.dae`` for the SCHUNK SVH right hand (link suffixes
  ``base_link, e1, e2, z, a, b, c, virtual_l, l, p, t, virtual_k, k, o, s,
  virtual_j, j, n, r, virtual_i, i, m, q``);
* ``meshes/ur5/<link>.dae`` for the UR5 (``base`` belongs on link
  ``base_link_inertia``; ``shoulder, upper_arm, forearm, wrist_1, wrist_2,
  wrist_3``).

Frame contract: every mesh is expressed in its link's frame (metres, Z up) and
is meant to be referenced with an identity origin.  For the SVH the link
frames are those of the FZI ``svh.urdf.xacro`` (side = 1, right hand); for
the UR5 those of ``ur_description`` (noetic), i.e. the rotations and offsets of
the vendor visual origins are already folded into the numbers below.

Mirror contract (the left hand reuses these files): ``e1``/``e2`` are scaled
by x -> -x, ``z`` by y -> -y and ``a``/``b``/``c`` by (y, z) -> (-y, -z).  The
vendor kinematics maps a right thumb link onto the left one by y -> -y, so
``a``/``b``/``c`` are built symmetric under z -> -z, which makes both mirrors
identical.  Finger links are not scaled at all, so they are built symmetric
under the mirror that the kinematics implies: y -> -y for ``virtual_*`` and
z -> -z (the flexion axis) for the phalanges.  ``check_symmetry`` verifies it.

Everything is authored in millimetres from a handful of primitives (rounded
boxes, cylinders, frusta, ellipsoids), combined with convex hulls and
manifold3d booleans into one closed, watertight piece per link, then scaled to
metres.  The output is byte-for-byte reproducible: the COLLADA ``<asset>`` has
fixed dates, the random ids that the exporter generates are replaced by ids
derived from the link name, and coordinates are rounded to 0.1 um.

Dimensions used (facts measured on the vendor meshes, placed in the link frame
with their visual origin; bounding boxes in mm, ``lo .. hi`` per axis)::

    SVH link    vendor mesh  x                y                z
    base_link   base10       -45.0 .. 45.0    -45.0 .. 45.0    -32.0 .. 13.5
    e1          h10          -36.2 .. 30.9    -15.9 .. 43.3      0.0 .. 121.5
    e2          h11          -11.1 .. 36.9    -21.5 .. 23.9    -10.0 .. 77.0
    z           d10          -15.2 .. 15.2    -11.9 .. 11.9     24.7 .. 59.1
    a           d11          -14.5 .. 62.8    -15.4 .. 18.1    -14.6 .. 14.6
    b           d12          -11.6 .. 36.5    -13.2 .. 11.9    -14.0 .. 14.0
    c           d13           -8.3 .. 27.8     -9.4 .. 10.8    -10.7 .. 10.7
    virtual_l   f10           -8.0 .. 11.5    -11.5 .. 11.5     -9.2 .. 13.3
    l           f11           -8.6 .. 56.6     -9.6 .. 11.2     -9.0 .. 9.0
    p           f12           -6.0 .. 31.5     -8.0 .. 8.9      -9.9 .. 9.9
    t           f13           -7.2 .. 22.5     -8.1 .. 8.6      -8.6 .. 8.6
    virtual_k   f20           -8.0 .. 11.5    -11.5 .. 11.5     -9.3 .. 13.2
    k           f21           -8.6 .. 58.6     -9.6 .. 11.3     -9.0 .. 9.0
    o           f22           -6.0 .. 37.5     -8.0 .. 8.9      -9.8 .. 9.8
    s           f23           -7.2 .. 22.4     -8.1 .. 8.6      -8.6 .. 8.6
    virtual_j   f30           -8.0 .. 11.5    -11.5 .. 11.5    -13.2 .. 9.4
    j           f31           -7.5 .. 58.7    -10.6 .. 11.4     -9.0 .. 9.0
    n           f32           -6.0 .. 37.5     -8.0 .. 8.9      -9.8 .. 9.8
    r           f33           -7.2 .. 22.4     -8.1 .. 8.6      -8.6 .. 8.6
    virtual_i   f40           -8.0 .. 11.5    -11.5 .. 11.5    -13.1 .. 9.4
    i           f41           -7.6 .. 53.1     -9.6 .. 11.3     -9.0 .. 9.0
    m           f42           -6.0 .. 27.5     -8.0 .. 6.0     -10.0 .. 10.0
    q           f43           -7.2 .. 22.5     -8.1 .. 8.6      -8.6 .. 8.6

    UR5 link    vendor mesh  x                y                z
    base        base         -73.6 .. 73.6    -73.6 .. 110.0     0.0 .. 24.0
    shoulder    shoulder     -59.5 .. 59.5    -70.5 .. 59.5    -65.2 .. 68.5
    upper_arm   upperarm    -484.9 .. 59.7    -59.5 .. 59.9     70.7 .. 204.4
    forearm     forearm     -431.3 .. 58.0    -58.5 .. 58.0    -40.7 .. 71.0
    wrist_1     wrist1       -38.9 .. 38.9    -47.5 .. 57.2    -45.5 .. 39.5
    wrist_2     wrist2       -38.9 .. 38.7    -57.2 .. 47.5    -45.9 .. 38.4
    wrist_3     wrist3       -37.5 .. 37.5    -43.0 .. 37.5    -34.5 .. 0.0

Further measured facts (mm): SVH finger joint pitches (from the xacro) 48.04 /
26 (index), 50.04 / 32 (middle, ring), 44.54 / 22 (little), thumb 48.5 / 30;
joint bosses r 8.6 (proximal), 6.0 (middle), 7.2 (distal), thumb r 11.8 (b)
and 8.3 (c); palm knuckle lobes r 11.3 at z 110 around x = -25 and 0; e2
knuckle lobes around (4, 65) and (25, 57).  UR5: joint housings r 58 (upper
arm, shoulder, elbow), 38 (forearm wrist end), 37.5 (wrists); upper-arm tube
r 50.3 at z 135.7; forearm tube r 37.7 at z 16.6; housing caps tilt about
0.13 rad toward the middle of the arm.
"""

from __future__ import annotations

import argparse
import hashlib
import math
from collections.abc import Callable, Sequence
from pathlib import Path

import numpy as np
import trimesh
from lxml import etree
from slice_solid import links, slice_solid
from vendor_envelopes import ENVELOPE_STEP, ENVELOPES

from svhdesc.core.exact import perturbed

ROOT = Path(__file__).resolve().parents[1]
OUT = ROOT / "meshes"
ROUND_M = 7  # decimals kept for coordinates in metres (0.1 um)
DATE = "2000-01-01T00:00:00"
MAX_TRIANGLES = 15000

_AXES = {"x": 0, "y": 1, "z": 2}
_PLANE = {0: (1, 2), 1: (2, 0), 2: (0, 1)}

Vec = Sequence[float]

# --------------------------------------------------------------------------
# primitives (millimetres)
# --------------------------------------------------------------------------


def _circle(center: Vec, axis: str, r: float, n: int) -> np.ndarray:
    """Points of a circle of radius ``r`` around ``center`` normal to ``axis``."""
    a = _AXES[axis]
    u, v = _PLANE[a]
    # Trigonometry differs in the last bit between libraries and CPUs (numpy's AVX-512 sin/cos do), and the hulls
    # and booleans below turn a last-bit difference into another triangulation: snap to 1e-12 first.
    ang = [k * (2.0 * math.pi / n) for k in range(n)]
    pts = np.tile(np.asarray(center, dtype=float), (n, 1))
    pts[:, u] += r * np.round(perturbed(np.array([math.cos(a) for a in ang])), 12)
    pts[:, v] += r * np.round(perturbed(np.array([math.sin(a) for a in ang])), 12)
    return pts


def hull_points(*pts: np.ndarray) -> trimesh.Trimesh:
    """Convex hull of point sets."""
    return trimesh.convex.convex_hull(np.vstack(pts))


def hull(*meshes: trimesh.Trimesh) -> trimesh.Trimesh:
    """Convex hull of meshes."""
    return hull_points(*[m.vertices for m in meshes])


def lathe(center: Vec, axis: str, profile: Sequence[tuple[float, float]], n: int = 32) -> trimesh.Trimesh:
    """Convex solid of revolution: circles of radius r at offset t along axis."""
    a = _AXES[axis]
    pts = []
    for t, r in profile:
        c = np.asarray(center, dtype=float).copy()
        c[a] += t
        pts.append(_circle(c, axis, r, n) if r > 0 else c[None, :])
    return hull_points(*pts)


def cyl(center: Vec, axis: str, t0: float, t1: float, r: float, n: int = 32) -> trimesh.Trimesh:
    """Cylinder around ``center`` along ``axis`` from offset t0 to t1."""
    return lathe(center, axis, [(t0, r), (t1, r)], n)


def chamfered_cyl(center: Vec, axis: str, t0: float, t1: float, r: float, c: float, n: int = 48) -> trimesh.Trimesh:
    """Cylinder with a 45 degree chamfer ``c`` on both rims."""
    return lathe(center, axis, [(t0, r - c), (t0 + c, r), (t1 - c, r), (t1, r - c)], n)


def ellipsoid(center: Vec, radii: Vec, subdiv: int = 3) -> trimesh.Trimesh:
    """Ellipsoid from a scaled icosphere."""
    m = trimesh.creation.icosphere(subdivisions=subdiv, radius=1.0)
    m.apply_scale(np.asarray(radii, dtype=float))
    m.apply_translation(np.asarray(center, dtype=float))
    return m


def rbox(lo: Vec, hi: Vec, r: float, subdiv: int = 1) -> trimesh.Trimesh:
    """Box from ``lo`` to ``hi`` with all edges rounded by radius ``r``."""
    lo_, hi_ = np.asarray(lo, float) + r, np.asarray(hi, float) - r
    if np.any(hi_ < lo_):
        raise ValueError(f"rbox {lo}..{hi} too small for radius {r}")
    ball = trimesh.creation.icosphere(subdivisions=subdiv, radius=r).vertices
    corners = [np.array([x, y, z]) for x in (lo_[0], hi_[0]) for y in (lo_[1], hi_[1]) for z in (lo_[2], hi_[2])]
    pts = np.vstack([ball + c for c in corners])
    # pin the exact faces of the box so the extents are exact
    pts = np.clip(pts, lo, hi)
    return hull_points(pts)


def box(lo: Vec, hi: Vec) -> trimesh.Trimesh:
    """Axis-aligned box."""
    lo_, hi_ = np.asarray(lo, float), np.asarray(hi, float)
    return trimesh.creation.box(
        extents=hi_ - lo_, transform=trimesh.transformations.translation_matrix((lo_ + hi_) / 2)
    )


def union(*meshes: trimesh.Trimesh) -> trimesh.Trimesh:
    """Boolean union (manifold3d)."""
    return trimesh.boolean.union(list(meshes), engine="manifold")


def diff(a: trimesh.Trimesh, *b: trimesh.Trimesh) -> trimesh.Trimesh:
    """Boolean difference a - b (manifold3d)."""
    return trimesh.boolean.difference([a, *b], engine="manifold")


def inter(*meshes: trimesh.Trimesh) -> trimesh.Trimesh:
    """Boolean intersection (manifold3d)."""
    return trimesh.boolean.intersection(list(meshes), engine="manifold")


def mirrored(m: trimesh.Trimesh, axis: str) -> trimesh.Trimesh:
    """Reflect a mesh across the plane normal to ``axis`` (winding fixed)."""
    s = np.ones(3)
    s[_AXES[axis]] = -1.0
    out = trimesh.Trimesh(m.vertices * s, m.faces[:, ::-1], process=False)
    return out


# --------------------------------------------------------------------------
# SVH (right hand), link frames of svh.urdf.xacro
# --------------------------------------------------------------------------


def svh_base_link() -> trimesh.Trimesh:
    """Wrist flange: a cup of r 45 over a r 32 spigot, with a cable bore."""
    outer = lathe((0, 0, 0), "z", [(-22.5, 43.0), (-20.0, 45.0), (12.5, 45.0), (13.5, 44.0)], n=64)
    spigot = lathe((0, 0, 0), "z", [(-32.0, 32.4), (-24.0, 29.5), (-21.0, 29.5)], n=48)
    cavity = cyl((0, 0, 0), "z", -18.5, 14.0, 41.5, n=64)
    bore = cyl((0, 0, 0), "z", -33.0, -17.0, 15.0, n=32)
    return diff(union(outer, spigot), cavity, bore)


def svh_e1() -> trimesh.Trimesh:
    """Palm (index and middle finger side) with the thumb base and knuckles."""
    parts = [
        rbox((-30.0, -15.4, 0.0), (30.9, 37.0, 27.0), 6.0),  # wrist block / thumb base
        ellipsoid((-19.0, 33.0, 15.0), (10.0, 10.3, 9.0), 2),  # thumb opposition housing
        rbox((-30.0, -15.4, 24.0), (20.5, 22.3, 62.0), 5.0),  # lower palm
        rbox((-33.9, -15.4, 56.0), (17.7, 22.3, 99.0), 5.0),  # upper palm
        hull(  # dorsal hump (motor covers)
            ellipsoid((9.0, 24.0, 44.0), (9.0, 17.0, 14.0), 2),
            ellipsoid((-16.0, 18.0, 66.0), (13.0, 14.0, 10.0), 2),
        ),
    ]
    for xc in (-25.0, 0.0):  # index (x = -25) and middle (x = 0) knuckles, axis at z = 110
        parts.append(
            hull(
                cyl((xc, 0, 110.0), "y", -15.4, -8.0, 11.3, 32),
                box((xc - 11.0, -15.4, 95.0), (xc + 11.0, -8.0, 100.0)),
            )
        )
        parts.append(rbox((xc - 4.5, 10.5, 95.0), (xc + 4.5, 16.0, 119.0), 1.5))
    # The vendor palm (h10) is recessed to x 10-11 between its palm and dorsal walls below the knuckles,
    # where the ring finger's base swings in as j5 folds the palm: a solid corner there stopped the ring finger.
    return diff(union(*parts), box((11.2, -12.5, 89.0), (19.0, 9.0, 102.0)))


def svh_e2() -> trimesh.Trimesh:
    """Ring/little finger half of the palm (rotates about j5, axis z)."""
    body = hull(
        rbox((-1.0, -20.5, -4.0), (30.5, -12.0, 42.0), 3.0),  # palm-side wall
        ellipsoid((17.0, 6.0, 8.0), (11.0, 17.85, 12.0), 2),  # dorsal bulge, low
        rbox((5.0, -20.5, 35.0), (30.5, 10.0, 45.0), 3.0),  # dorsal top
        rbox((-11.1, -20.5, -10.0), (20.0, -13.0, -4.0), 2.0),  # lower flange
    )
    plate = hull(  # knuckle plate with the ring (4, 65) and little (25, 57) lobes
        cyl((4.0, 0, 65.0), "y", -21.5, -14.0, 12.0, 32),
        cyl((25.0, 0, 57.0), "y", -21.5, -14.0, 11.9, 32),
        box((-6.0, -21.5, 36.0), (30.0, -14.0, 44.0)),
    )
    column = rbox((-6.5, -20.5, -4.0), (0.0, -13.0, 46.0), 1.5)
    top = rbox((-5.0, -15.0, 38.0), (6.0, 1.0, 54.0), 2.0)
    return union(body, plate, column, top)


def svh_z() -> trimesh.Trimesh:
    """Thumb opposition link: a U-bracket holding the thumb flexion axis (x, z 46)."""
    parts = [
        cyl((0, 0, 0), "z", 24.73, 27.5, 6.5, 24),
        rbox((-15.17, -9.5, 26.5), (15.17, 10.5, 32.0), 2.0),
    ]
    for x0, x1 in ((10.0, 15.17), (-15.17, -10.0)):
        parts.append(hull(box((x0, -11.85, 26.5), (x1, 11.93, 34.0)), cyl((0, 0, 47.1), "x", x0, x1, 12.0, 32)))
    return union(*parts)


def svh_a() -> trimesh.Trimesh:
    """Thumb proximal: root block, flexion motor and shaft (axis z at 0, next at x 48.5)."""
    return union(  # coarse corners: the vendor slices clip them (triangle budget)
        rbox((-14.45, -15.35, -9.6), (16.0, 18.11, 9.6), 4.0, 0),
        rbox((15.0, -15.35, -14.6), (40.0, 15.5, 14.6), 4.0, 1),
        rbox((38.0, -15.35, -9.2), (62.8, 13.8, 9.2), 5.0, 1),
    )


def svh_b() -> trimesh.Trimesh:
    """Thumb middle: a fork around the a/b joint narrowing to a fork at x 30."""
    solid = hull(
        cyl((0, 0, 0), "z", -14.04, 14.04, 11.8, 32),
        rbox((8.0, -13.24, -12.0), (14.0, 10.5, 12.0), 2.0),
        rbox((24.0, -10.0, -9.0), (36.5, 7.0, 9.0), 3.0),
    )
    return diff(solid, box((-13.0, -15.0, -9.8), (9.0, 15.0, 9.8)), box((27.0, -15.0, -7.2), (40.0, 15.0, 7.2)))


def svh_c() -> trimesh.Trimesh:
    """Thumb distal: joint boss and a rounded fingertip."""
    return union(
        cyl((0, 0, 0), "z", -7.0, 7.0, 8.3, 24),
        ellipsoid((12.0, 0.7, 0.0), (15.78, 10.09, 10.68), 2),
    )


def svh_virtual(up: bool) -> trimesh.Trimesh:
    """Finger base bracket (spread link): a U-shaped yoke around the flexion axis."""
    # D-shaped plan, r 11.5, from z -9.24 to 8.2. Both rims rounded as on the vendor part (f20: r 9.0 at
    # 0.7 mm from the flat end, 11.0 at 2.7 mm, full 11.5 from 4.2 mm; 10.2 at z 8.0 toward the neck): a sharp
    # rim there touched the neighbouring bracket when j5 folds the palm, 1.2-2.7 mm before the real parts do.
    rim = [(-9.24, 8.6), (-8.5, 9.0), (-7.5, 9.9), (-6.5, 10.9), (-5.5, 11.3), (-5.0, 11.5), (7.5, 11.5), (8.2, 10.0)]
    d = inter(
        lathe((0, 0, 0), "z", rim, 48),
        box((-8.0, -12.0, -10.0), (12.0, 12.0, 11.0)),
        hull_points(  # lower front edge bevelled (profile in x-z)
            np.array(
                [
                    [x, y, z]
                    for x, z in ((-9.0, -9.24), (3.0, -9.24), (12.0, 0.0), (12.0, 11.0), (-9.0, 11.0))
                    for y in (-12.0, 12.0)
                ]
            )
        ),
    )
    slot = union(  # arched slot for the proximal phalanx, open at the back (x < -5)
        box((-9.0, -6.0, -10.0), (12.0, 6.0, 1.5)),
        cyl((0, 0, 1.5), "x", -9.0, 12.0, 6.0, 32),
        box((-9.0, -6.0, -10.0), (-5.0, 6.0, 14.0)),
    )
    d = diff(d, slot)
    m = union(d, rbox((-5.0, -5.0, 7.5), (5.0, 5.0, 13.28), 1.5))
    return m if up else mirrored(m, "z")


def svh_proximal(pitch: float, ylo: float, yhi: float, boss: float) -> trimesh.Trimesh:
    """Proximal phalanx: boss at the joint, body, rounded distal end at ``pitch``."""
    return union(
        cyl((0, 0, 0), "z", -6.0, 6.0, boss, 32),
        rbox((0.0, -8.0, -5.8), (11.0, 6.0, 5.8), 2.0),
        hull(
            rbox((9.0, ylo, -9.0), (pitch - 4.0, yhi, 9.0), 4.0),
            cyl((pitch, 0.8, 0), "z", -7.5, 7.5, 8.6, 32),
        ),
    )


def svh_middle(pitch: float, ylo: float, yhi: float, zmax: float) -> trimesh.Trimesh:
    """Middle phalanx: forks at both joints (0 and ``pitch``)."""
    solid = hull(
        cyl((0, 0, 0), "z", -zmax, zmax, 6.0, 32),
        rbox((7.0, ylo, -7.5), (pitch, yhi, 7.5), 3.0),
        cyl((pitch, 0, 0), "z", -8.3, 8.3, 5.5, 32),
    )
    return diff(
        solid,
        box((-7.0, -10.0, -7.0), (4.0, 10.0, 7.0)),
        box((pitch - 2.0, -10.0, -5.6), (pitch + 7.0, 10.0, 5.6)),
        # the distal fork opens toward the palm 7 mm before the joint (vendor f22/f32: slot |z| < 4.5)
        box((pitch - 7.0, -6.0, -4.5), (pitch + 7.0, 10.0, 4.5)),
    )


def svh_distal() -> trimesh.Trimesh:
    """Distal phalanx: joint boss and a rounded fingertip (tip at x 22.5)."""
    return union(
        cyl((0, 0, 0), "z", -6.0, 6.0, 7.22, 32),
        ellipsoid((11.5, 0.27, 0.0), (10.96, 8.33, 8.57), 2),
    )


MERGE_MM = 0.2


def envelope(name: str) -> trimesh.Trimesh:
    """The measured envelope of the vendor part (vendor_envelopes.py): one 16-sided prism per slab."""
    # Neighbouring slabs within MERGE_MM of each other become one (their larger support): fewer steps.
    runs: list[tuple[float, float, list[float]]] = []
    for x, *half in ENVELOPES[name]:
        lo, hi = x - ENVELOPE_STEP / 2, x + ENVELOPE_STEP / 2
        if runs and max(abs(a - b) for a, b in zip(runs[-1][2], half)) < MERGE_MM:
            runs[-1] = (runs[-1][0], hi, [max(a, b) for a, b in zip(runs[-1][2], half)])
        else:
            runs.append((lo, hi, list(half)))
    prisms = []
    for lo, hi, half in runs:
        support = [*half, *half[-2:0:-1]]  # h(-theta) = h(theta): 0 .. 180 degrees, then back to 0
        yz = _polygon(support)
        ends = [np.column_stack([np.full(len(yz), x), yz]) for x in (lo, hi)]
        prisms.append(hull_points(*ends))
    return union(*prisms)


def _polygon(support: Sequence[float]) -> np.ndarray:
    """Corners of the polygon whose side k lies at distance support[k] along direction k * 360 / n degrees.

    Neighbouring sides meet where both side equations hold. numpy's LAPACK solve (OpenBLAS's per-CPU kernels) gave
    other last bits on an AVX-512 CPU than on an AVX2 one, and the clipping downstream turned that into another
    triangulation of every fitted part (issue 14); so did a 4-ulp nudge of the directions, so they are not snapped
    or perturbed: the C library's cos/sin of these angles are the same bits with and without FMA
    (tests/compiler/pipeline/test_determinism.py runs this script as other CPUs), and the solve is LAPACK's
    partial-pivoting LU in plain IEEE arithmetic (no FMA), which reproduces the committed meshes' bits."""
    n = len(support)
    angles = [math.radians(k * 360.0 / n) for k in range(n)]
    cos, sin = [math.cos(a) for a in angles], [math.sin(a) for a in angles]
    corners = []
    for k in range(n):
        j = (k + 1) % n
        corners.append(_solve2((cos[k], sin[k], support[k]), (cos[j], sin[j], support[j])))
    return np.array(corners, dtype=float)


def _solve2(first: tuple[float, float, float], second: tuple[float, float, float]) -> tuple[float, float]:
    """(y, z) with a * y + b * z = h for both rows (a, b, h): LU with partial pivoting, as LAPACK's getrf/getrs."""
    (a0, b0, h0), (a1, b1, h1) = (second, first) if abs(second[0]) > abs(first[0]) else (first, second)
    multiplier = a1 * (1.0 / a0)
    z = (h1 - multiplier * h0) / (b1 - multiplier * b0)
    return (h0 - b0 * z) / a0, z


def fitted(make: Callable[[], trimesh.Trimesh], name: str) -> Callable[[], trimesh.Trimesh]:
    """An authored part clipped to the vendor part's convex slab envelope and to its slices (tools/slice_solid.py):
    a primitive that bulges past the real part (a rounded box where the phalanx tapers, a block across a fork's
    slot or a groove) would make the fingers collide where the real ones pass. The slices keep the grooves and
    forks that the convex envelope fills; the envelope (16 directions) follows rounded ends closer than the
    slices' 1 mm steps (those left the fingertips up to 1 mm outside the vendor part)."""
    return lambda: simplified(inter(make(), envelope(name), slice_solid(name)))


SIMPLIFY_MM = 1e-3


def simplified(mesh: trimesh.Trimesh) -> trimesh.Trimesh:
    """Edges shorter and needles thinner than SIMPLIFY_MM collapsed (manifold3d): clipping by the slices left
    triangles a fraction of a micrometre wide, which rounding to 0.1 um made degenerate (a hole once dropped)."""
    import manifold3d

    vertices, faces = np.asarray(mesh.vertices, np.float64), np.asarray(mesh.faces, np.uint64)
    out = manifold3d.Manifold(manifold3d.Mesh64(vertices, faces)).simplify(SIMPLIFY_MM).to_mesh64()
    return trimesh.Trimesh(np.asarray(out.vert_properties)[:, :3], np.asarray(out.tri_verts), process=False)


SVH: dict[str, Callable[[], trimesh.Trimesh]] = {
    "base_link": svh_base_link,
    "e1": svh_e1,
    "e2": svh_e2,
    "z": svh_z,
    "a": svh_a,
    "b": svh_b,
    "c": svh_c,
    "virtual_l": lambda: svh_virtual(True),
    "l": lambda: svh_proximal(48.04, -9.61, 11.23, 8.57),
    "p": lambda: svh_middle(26.0, -7.96, 8.9, 9.85),
    "t": svh_distal,
    "virtual_k": lambda: svh_virtual(True),
    "k": lambda: svh_proximal(50.04, -9.55, 11.28, 8.59),
    "o": lambda: svh_middle(32.0, -7.97, 8.9, 9.8),
    "s": svh_distal,
    "virtual_j": lambda: svh_virtual(False),
    "j": lambda: svh_proximal(50.04, -10.58, 11.38, 7.53),
    "n": lambda: svh_middle(32.0, -7.96, 8.9, 9.8),
    "r": svh_distal,
    "virtual_i": lambda: svh_virtual(False),
    "i": lambda: svh_proximal(44.54, -9.62, 11.34, 7.64),
    "m": lambda: svh_middle(22.0, -7.98, 6.03, 9.96),
    "q": svh_distal,
}
SVH |= {name: fitted(SVH[name], name) for name in links() if name in ENVELOPES}

# mirror (axis name) under which a link mesh must be invariant
SVH_SYMMETRY = {
    **{k: "y" for k in ("virtual_l", "virtual_k", "virtual_j", "virtual_i")},
    **{k: "z" for k in ("a", "b", "c", "l", "p", "t", "k", "o", "s", "j", "n", "r", "i", "m", "q")},
}

# --------------------------------------------------------------------------
# UR5, link frames of ur_description (noetic)
# --------------------------------------------------------------------------


def _tilted_cap(cx: float, r: float, z0: float, z_top: Callable[[np.ndarray], np.ndarray], n: int = 64) -> np.ndarray:
    """Rim points of a z-axis housing at x = cx whose top is z_top(x, y)."""
    ring = _circle((cx, 0, 0), "z", r, n)
    inner = _circle((cx, 0, 0), "z", r - 12.0, n)
    top_outer = ring.copy()
    top_outer[:, 2] = z_top(ring) - 8.0
    top_inner = inner.copy()
    top_inner[:, 2] = z_top(inner)
    bottom = _circle((cx, 0, z0), "z", r - 1.5, n)
    bottom_rim = _circle((cx, 0, z0 + 1.5), "z", r, n)
    return np.vstack([top_outer, top_inner, bottom, bottom_rim])


def ur_base() -> trimesh.Trimesh:
    """Mounting plate r 73.5 with the r 58 bearing ring and the cable outlet (+y)."""
    return union(
        lathe(
            (0, 0, 0),
            "z",
            [(0.0, 72.5), (1.0, 73.5), (16.0, 73.5), (17.0, 72.5), (17.0, 58.0), (24.0, 58.0)],
            n=64,
        ),
        rbox((-5.1, 60.0, 3.3), (5.1, 110.0, 13.7), 1.5),
    )


def ur_shoulder() -> trimesh.Trimesh:
    """Shoulder: vertical housing (pan joint) with a tilted cap, lift housing toward -y."""
    vert = hull_points(_tilted_cap(0.0, 58.0, -65.2, lambda p: 61.0 - 0.13 * p[:, 1]))
    horiz = chamfered_cyl((0, 0, 0), "y", -70.5, 0.0, 58.0, 3.0, n=64)
    return union(vert, horiz)


def ur_upper_arm() -> trimesh.Trimesh:
    """Upper arm: housings at the shoulder (x 0) and elbow (x -425), tube r 50.3."""
    a = hull_points(_tilted_cap(0.0, 58.5, 70.7, lambda p: 197.4 - 0.13 * p[:, 0]))
    b = hull_points(_tilted_cap(-425.0, 58.5, 70.7, lambda p: 197.4 + 0.13 * (p[:, 0] + 425.0)))
    tube = cyl((0, 0, 135.7), "x", -425.0, 0.0, 50.3, n=48)
    return union(a, b, tube)


def ur_forearm() -> trimesh.Trimesh:
    """Forearm: elbow housing with a rounded underside, tube r 37.7, wrist housing."""
    elbow = lathe(
        (0, 0, 0),
        "z",
        [(-10.0, 0.0), (-8.0, 10.0), (5.0, 30.0), (27.5, 50.0), (45.0, 58.0), (68.0, 58.0), (71.0, 55.0)],
        n=64,
    )
    tube = cyl((0, 0, 16.6), "x", -392.25, 0.0, 37.7, n=48)
    wrist = lathe((-392.25, 0, 0), "z", [(-40.7, 30.0), (-34.0, 38.5), (64.0, 38.5)], n=48)
    return union(elbow, tube, wrist)


def ur_wrist(sign: float, zlo: float) -> trimesh.Trimesh:
    """Wrist 1/2: housing of the next joint along y, stub toward the previous one."""
    y0, y1 = (-47.5, 57.2) if sign > 0 else (-57.2, 47.5)
    return union(
        chamfered_cyl((0, 0, 0), "y", y0, y1, 37.5, 2.0, n=48),
        lathe((0, 0, 0), "z", [(zlo, 36.0), (zlo + 1.5, 37.5), (0.0, 37.5)], n=48),
    )


def ur_wrist_3() -> trimesh.Trimesh:
    """Wrist 3: housing r 37.5, tool flange r 31.5 at z 0, connector toward -y."""
    return union(
        lathe(
            (0, 0, 0),
            "z",
            [(-34.5, 36.0), (-33.0, 37.5), (-8.0, 37.5), (-6.5, 36.0), (-6.5, 31.5), (0.0, 31.5)],
            n=64,
        ),
        rbox((-5.0, -43.0, -24.0), (5.0, -30.0, -15.0), 1.5),
    )


UR5: dict[str, Callable[[], trimesh.Trimesh]] = {
    "base": ur_base,
    "shoulder": ur_shoulder,
    "upper_arm": ur_upper_arm,
    "forearm": ur_forearm,
    "wrist_1": lambda: ur_wrist(1.0, -45.5),
    "wrist_2": lambda: ur_wrist(-1.0, -45.9),
    "wrist_3": ur_wrist_3,
}

# diffuse colours (RGBA 0..255)
GREY_ALU = (115, 115, 115, 255)
DARK = (60, 60, 60, 255)
RUBBER = (26, 26, 26, 255)
UR_GREY = (179, 179, 179, 255)
UR_BLUE = (90, 140, 200, 255)

SVH_COLOUR = {k: DARK for k in SVH} | {
    "base_link": GREY_ALU,
    "e1": GREY_ALU,
    "e2": GREY_ALU,
    "z": GREY_ALU,
    **{k: RUBBER for k in ("c", "t", "s", "r", "q")},
}
UR5_COLOUR = {k: UR_GREY for k in UR5} | {"wrist_3": UR_BLUE}

# --------------------------------------------------------------------------
# finishing, checks and export
# --------------------------------------------------------------------------


def symmetrize(mesh: trimesh.Trimesh, axis: str) -> trimesh.Trimesh:
    """Make a mesh exactly mirror-symmetric: keep the + half, mirror it, weld.

    Booleans of symmetric solids are not symmetric triangle-by-triangle (box
    faces are split along one diagonal), so the vertex sets would differ.
    """
    a = _AXES[axis]
    normal = np.zeros(3)
    normal[a] = 1.0
    half = trimesh.intersections.slice_mesh_plane(mesh, normal, np.zeros(3), cap=False)
    v = np.array(half.vertices, dtype=float)
    v[np.abs(v[:, a]) < 1e-6, a] = 0.0
    half = trimesh.Trimesh(v, half.faces, process=False)
    both = trimesh.util.concatenate([half, mirrored(half, axis)])
    both.merge_vertices(digits_vertex=6)
    both.update_faces(both.nondegenerate_faces())
    both.remove_unreferenced_vertices()
    return both


def finish(mesh_mm: trimesh.Trimesh, name: str) -> trimesh.Trimesh:
    """Scale to metres, round, clean and check a closed single-piece mesh."""
    v = np.round(np.asarray(mesh_mm.vertices, dtype=float) * 1e-3, ROUND_M) + 0.0
    m = trimesh.Trimesh(v, mesh_mm.faces, process=False)
    m.merge_vertices(digits_vertex=ROUND_M + 1)
    m.update_faces(m.nondegenerate_faces())
    m.update_faces(m.unique_faces())
    m.remove_unreferenced_vertices()
    trimesh.repair.fix_normals(m)
    if not m.is_watertight or not m.is_winding_consistent:
        raise RuntimeError(f"{name}: mesh is not closed")
    if m.volume <= 0:
        raise RuntimeError(f"{name}: mesh is inside out")
    bodies = m.split(only_watertight=False)
    if len(bodies) != 1:
        raise RuntimeError(f"{name}: {len(bodies)} separate pieces")
    if len(m.faces) > MAX_TRIANGLES:
        raise RuntimeError(f"{name}: {len(m.faces)} triangles, too heavy")
    return m


def check_symmetry(mesh: trimesh.Trimesh, axis: str, name: str, tol: float = 1e-6) -> None:
    """Require the mesh to be invariant (as a point set) under a mirror."""
    from scipy.spatial import cKDTree

    s = np.ones(3)
    s[_AXES[axis]] = -1.0
    d, _ = cKDTree(mesh.vertices).query(mesh.vertices * s)
    if d.max() > tol:
        raise RuntimeError(f"{name}: not symmetric under {axis} -> -{axis} ({d.max():.2e} m)")


def vertex_normals(mesh: trimesh.Trimesh) -> np.ndarray:
    """Area-weighted unit vertex normals rounded to 1e-6, computed element-wise (trimesh's go through BLAS,
    whose per-CPU kernels changed the last digits, and near-zero components in every digit)."""
    tri = np.asarray(mesh.vertices, dtype=float)[np.asarray(mesh.faces)]
    cross = perturbed(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]))
    sums = np.zeros((len(mesh.vertices), 3))
    for corner in range(3):
        np.add.at(sums, np.asarray(mesh.faces)[:, corner], cross)
    length = np.sqrt(sums[:, 0] * sums[:, 0] + sums[:, 1] * sums[:, 1] + sums[:, 2] * sums[:, 2])
    return np.round(sums / length[:, None], 6) + 0.0


def collada_bytes(mesh: trimesh.Trimesh, name: str, rgba: Sequence[int]) -> bytes:
    """Export with trimesh, then make the document reproducible and Z-up in metres."""
    m = mesh.copy()
    m.visual = trimesh.visual.ColorVisuals(m, face_colors=np.tile(np.asarray(rgba, np.uint8), (len(m.faces), 1)))
    m.vertex_normals = vertex_normals(m)
    raw = trimesh.exchange.dae.export_collada(m)
    root = etree.fromstring(raw, etree.XMLParser(remove_blank_text=True))
    ns = root.nsmap[None]
    q = f"{{{ns}}}"

    asset = root.find(q + "asset")
    for child in list(asset):
        asset.remove(child)
    contributor = etree.SubElement(asset, q + "contributor")
    etree.SubElement(contributor, q + "authoring_tool").text = "svhdesc tools/author_meshes.py"
    etree.SubElement(asset, q + "created").text = DATE
    etree.SubElement(asset, q + "modified").text = DATE
    unit = etree.SubElement(asset, q + "unit")
    unit.set("name", "meter")
    unit.set("meter", "1")
    etree.SubElement(asset, q + "up_axis").text = "Z_UP"

    # replace the random uuid ids with ids derived from the link name
    kinds = {"effect": "effect", "material": "material", "geometry": "mesh"}
    rename: dict[str, str] = {}
    for tag, suffix in kinds.items():
        for el in root.iter(q + tag):
            new = f"{name}-{suffix}"
            rename[el.get("id")] = new
            el.set("id", new)
            el.set("name", new)
    for el in root.iter():
        for attr in ("url", "target", "source"):
            val = el.get(attr)
            if val and val.startswith("#") and val[1:] in rename:
                el.set(attr, "#" + rename[val[1:]])
    for el in root.iter(q + "node"):
        el.set("id", name)
        el.set("name", name)
    return etree.tostring(root, xml_declaration=True, encoding="utf-8", pretty_print=True)


def build(out: Path = OUT, only: Sequence[str] = (), quiet: bool = False) -> dict[str, trimesh.Trimesh]:
    """Build, check and write the meshes under ``out``; return them keyed by 'svh/<link>' etc."""
    built: dict[str, trimesh.Trimesh] = {}
    for robot, table, colours in (("svh", SVH, SVH_COLOUR), ("ur5", UR5, UR5_COLOUR)):
        (out / robot).mkdir(parents=True, exist_ok=True)
        for name, make in table.items():
            key = f"{robot}/{name}"
            if only and key not in only and name not in only:
                continue
            raw = make()
            if robot == "svh" and name in SVH_SYMMETRY:
                raw = symmetrize(raw, SVH_SYMMETRY[name])
            mesh = finish(raw, key)
            if robot == "svh" and name in SVH_SYMMETRY:
                check_symmetry(mesh, SVH_SYMMETRY[name], key)
            data = collada_bytes(mesh, name, colours[name])
            (out / robot / f"{name}.dae").write_bytes(data)
            built[key] = mesh
            if not quiet:
                digest = hashlib.sha256(data).hexdigest()[:12]
                print(f"{key:16s} {len(mesh.faces):5d} tris  {mesh.volume * 1e6:8.2f} cm3  {digest}")
    return built


def main(argv: Sequence[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--out", type=Path, default=OUT, help="output folder (default: meshes/)")
    parser.add_argument("only", nargs="*", help="links to build, e.g. svh/e1 or wrist_3 (default: all)")
    args = parser.parse_args(argv)
    build(args.out, args.only)


if __name__ == "__main__":
    main()
