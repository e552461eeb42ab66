"""Why does collision_fidelity list a pair: the authored mesh or only its convex hulls?

Run as ``python tools/fidelity_diagnosis.py [generated/svh_right]``. For each pair the check lists (at the pose it
reports), prints the collision depth, the gap between our authored (visual) meshes and the vendor gap, and for
each part how far our authored surface near the contact lies outside the vendor part (mm). A pair whose authored
meshes are closer than the vendor's is an authoring fault (tools/author_meshes.py); one whose authored meshes keep
the vendor gap is a decomposition fault (config/svhdesc.yaml, collision classes).
"""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Any

import numpy as np
import trimesh

from svhdesc.model import couplings
from svhdesc.validate.collision_fidelity import _frame, base_qpos, check_collision_fidelity, hand_prefix, place
from svhdesc.validate.options import Options
from svhdesc.validate.pair import load_pair
from svhdesc.validate.vendor_geometry import VendorLink, default_vendor_meshes, vendor_links

NEAR = 3e-3  # m: our surface within this of a contact point is judged against the vendor part


def excess_near(ours: trimesh.Trimesh, vendor: VendorLink, points: list[np.ndarray]) -> float:
    """Largest distance (m) of our surface samples near ``points`` (link frame) outside the vendor part."""
    samples, _ = trimesh.sample.sample_surface(ours, 40000, seed=0)
    near = samples[np.min([np.linalg.norm(samples - p, axis=1) for p in points], axis=0) < NEAR]
    if len(near) == 0:
        return 0.0
    _, distance, _ = trimesh.proximity.closest_point(vendor.mesh, near)
    inside = vendor.mesh.contains(near) if vendor.mesh.is_watertight else np.zeros(len(near), bool)
    return float(np.where(inside, 0.0, distance).max())


def our_link(path: Path) -> VendorLink:
    from scipy.spatial import cKDTree

    mesh = trimesh.load(path)
    samples, _ = trimesh.sample.sample_surface(mesh, max(500, int(mesh.area / 0.5e-3**2)), seed=0)
    points = np.vstack([samples, mesh.vertices])
    return VendorLink(mesh, points, cKDTree(points))


def diagnose(folder: Path) -> list[str]:
    import mujoco

    pair = load_pair(folder / f"{folder.name}.urdf", folder / f"{folder.name}.xml")
    (check,) = check_collision_fidelity(pair, Options(vendor_meshes=default_vendor_meshes()))
    model: Any = pair.model
    prefix = hand_prefix(model)
    vendor = vendor_links(default_vendor_meshes(), "left" if str(prefix).startswith("left") else "right")
    data, base, equalities = mujoco.MjData(model), base_qpos(model), couplings(model)
    lines = [f"{folder.name}: {check.value}"]
    for finding in check.data.get("findings", []):
        names = finding["bodies"]
        place(model, data, base, {f"{prefix}_{k}": v for k, v in finding["pose"].items()}, equalities)
        ids = [model.body(n).id for n in names]
        contacts = [
            c.pos.copy()
            for c in data.contact[: data.ncon]
            if {int(model.geom_bodyid[c.geom1]), int(model.geom_bodyid[c.geom2])} == set(ids)
        ]
        parts = [n.removeprefix(f"{prefix}_") for n in names]
        ours = [our_link(folder / "assets" / f"{p}.stl") for p in parts]
        frames = [_frame(data, i) for i in ids]
        gap = ours[0].distance(ours[1], np.linalg.inv(frames[1]) @ frames[0])
        excess = []
        for part, link, frame in zip(parts, ours, frames):
            local = [(np.linalg.inv(frame) @ np.r_[p, 1.0])[:3] for p in contacts]
            excess.append(f"{part} {excess_near(link.mesh, vendor[part], local) * 1e3:.2f}" if local else f"{part} -")
        lines.append(
            f"  {parts[0]}/{parts[1]}: depth {finding['depth_mm']:.2f}, ours {gap * 1e3:.2f} apart, "
            f"vendor {finding['vendor_gap_mm']:.2f} apart; authored surface outside the vendor part: "
            + ", ".join(excess)
        )
    return lines


def main(argv: list[str]) -> None:
    for folder in argv or ["generated/svh_right"]:
        print("\n".join(diagnose(Path(folder))))


if __name__ == "__main__":
    main(sys.argv[1:])
