"""Measure the 1 mm x 1 mm slices of the vendor finger and thumb parts; writes tools/vendor_slices.json.

Run as ``python tools/measure_vendor_slices.py [VENDOR_FOLDER]`` (default: ../shared/vendor/schunk_svh_driver).
Per link (frame of svh.urdf.xacro, right hand, mm): slabs SLAB long in x from x0; in each, per level z = 0,
0.5, 1.0, ... the y-extent of the vendor part over the band ``|z - level| <= BAND / 2`` taken on both sides
(``+z`` and ``-z``: the parts are treated as symmetric under z -> -z, as the authored ones are). The slab cuts the
part in full along y, so the y-extent of its surface in a band is that of the solid: exact, from the triangles
clipped to the band (no sampling). A band without any surface is a gap (a fork's slot) and is left out. The top
level is clamped to the slab's largest |z|. ylo is rounded down and yhi up to 0.1 mm, so that each slice contains
the vendor part's.

Only the measured numbers are written (facts about the vendor parts); tools/author_meshes.py clips each authored
part to the solid they describe, so that the collision geometry made from it keeps the real part's grooves and
forks, which convex slab envelopes filled.
"""

from __future__ import annotations

import json
import math
import sys
from pathlib import Path

import numpy as np
import trimesh

ROOT = Path(__file__).resolve().parents[1]
OUT = ROOT / "tools" / "vendor_slices.json"
LINKS = ("a", "b", "c", "l", "p", "t", "k", "o", "s", "j", "n", "r", "i", "m", "q")
SLAB = 1.0  # mm, slab length along x
LEVEL = 0.5  # mm between levels
BAND = 1.0  # mm, band height around a level


def clip(mesh: trimesh.Trimesh, axis: int, lo: float, hi: float) -> trimesh.Trimesh | None:
    """The surface of ``mesh`` with lo <= coordinate <= hi (None when empty)."""
    for sign, value in ((1.0, lo), (-1.0, hi)):
        normal = np.zeros(3)
        normal[axis] = sign
        origin = np.zeros(3)
        origin[axis] = value
        if len(mesh.faces) == 0:
            return None
        mesh = trimesh.intersections.slice_mesh_plane(mesh, normal, origin, cap=False)
    return mesh if len(mesh.faces) else None


def slices(mesh: trimesh.Trimesh) -> list[tuple[float, list[tuple[float, float, float]]]]:
    """[(x0, [(level, ylo, yhi), ...]), ...] of a mesh in mm."""
    out = []
    for x0 in np.arange(math.floor(mesh.bounds[0][0]), mesh.bounds[1][0], SLAB):
        slab = clip(mesh, 0, float(x0), float(x0 + SLAB))
        if slab is None:
            continue
        zmax = float(np.abs(slab.vertices[:, 2]).max())
        levels = []
        for level in np.arange(0.0, zmax + LEVEL, LEVEL):
            ys = []
            for centre in {float(level), -float(level)}:
                band = clip(slab, 2, centre - BAND / 2, centre + BAND / 2)
                if band is not None:
                    ys.extend([band.vertices[:, 1].min(), band.vertices[:, 1].max()])
            if ys:
                z = math.ceil(min(float(level), zmax) * 10 - 1e-6) / 10
                levels.append((z, math.floor(min(ys) * 10 + 1e-6) / 10, math.ceil(max(ys) * 10 - 1e-6) / 10))
        out.append((float(x0), levels))
    return out


def main(argv: list[str]) -> None:
    sys.path.insert(0, str(ROOT))
    from svhdesc.validate.vendor_geometry import default_vendor_meshes, vendor_links

    folder = Path(argv[0]) if argv else default_vendor_meshes()
    vendor = vendor_links(folder.resolve(), "right")
    rows = []
    for name in LINKS:
        mesh = vendor[name].mesh.copy()
        mesh.apply_scale(1e3)
        for x0, levels in slices(mesh):
            rows.append(json.dumps([name, x0, [[z, lo, hi] for z, lo, hi in levels]], separators=(",", ":")))
    header = {
        "about": "slices of the vendor finger and thumb parts, measured by tools/measure_vendor_slices.py (see there)",
        "units": "mm, link frame of svh.urdf.xacro, right hand",
        "rows": "[link, x0, [[level, ylo, yhi], ...]]: slab x0 .. x0 + slab, bands |z -+ level| <= band / 2",
        "slab": SLAB,
        "level": LEVEL,
        "band": BAND,
    }
    OUT.write_text('{"header": ' + json.dumps(header) + ',\n"rows": [\n' + ",\n".join(rows) + "\n]}\n")
    print(f"wrote {OUT.relative_to(ROOT)}")


if __name__ == "__main__":
    main(sys.argv[1:])
