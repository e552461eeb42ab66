"""The sizes of robot svhdesc answers for, stated once: past them a command refuses at once, naming the limit,
instead of working for minutes or failing deep inside (issue 48: a 1,000-link chain ran the build's MJCF writer
past Python's recursion limit; 10,000 links made validate's full tier simulate for hours).

Measured (benchmarks/scale_bench.py, docs/results/scale.md): `validate --tier static` is linear in the links up to
10,000; init's loads are linear too, but init and build take at most MAX_LINKS links, MAX_DEPTH deep (the build's
collision probes grow with the square of the bodies); the full tier's simulations grow faster than the joints (a
100-link chain: about a minute on 2 cores), so it takes at most MAX_SIMULATED_JOINTS.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path

MAX_LINKS = 500  # links of a robot init and build take: the build's probes test every pair of bodies (200 siblings:
# 22 s of probes on 2 loaded cores, growing with the square); the biggest robot of example-robot-data has 130
MAX_DEPTH = 250  # links from the root to the deepest leaf: the MJCF nests a body per link; libxml2 reads 256 levels
MAX_SIMULATED_JOINTS = 128  # movable joints of a model validate's full tier simulates (tiago_dual has 101)
# bytes of a mesh file any command reads: the biggest of 3,226 robot meshes (example-robot-data, pybullet_data,
# dm_control, gymnasium-robotics, robosuite) is go1's trunk.dae, 27 MB; a 100 MB STL took trimesh 1.1 GB and 17 s
MAX_MESH_BYTES = 64 << 20
# triangles of a mesh the build reads: MuJoCo reads no STL of more ('number of faces should be between 1 and 200000');
# a million took the build 155 s and 1.9 GB before MuJoCo refused it
MAX_MESH_TRIANGLES = 200_000


def mesh_size_problem(path: Path) -> str | None:
    """Why a mesh file is too big to read (its size against MAX_MESH_BYTES), or None; the file must exist."""
    size = path.stat().st_size
    if size <= MAX_MESH_BYTES:
        return None
    return f"{size / 2**20:.0f} MB, more than the {MAX_MESH_BYTES >> 20} MB svhdesc reads in a mesh file"


def tree_depth(parent_of: Mapping[str, str]) -> int:
    """The most links on a path from a root to a leaf (a root alone: 1), from each link's parent; linear in the
    links (each link's depth is found once). A cycle counts its links once, as a path."""
    depth: dict[str, int] = {}
    for start in parent_of:
        path, on_path, link = [], set(), start
        while link in parent_of and link not in depth and link not in on_path:
            path.append(link)
            on_path.add(link)
            link = parent_of[link]
        known = depth.get(link, 1)
        for walked in reversed(path):
            known += 1
            depth[walked] = known
    return max(depth.values(), default=1)


def links_problem(links: int) -> str | None:
    """Why a robot of ``links`` links is too big to build, or None."""
    if links <= MAX_LINKS:
        return None
    return (
        f"{links:,} links, more than the {MAX_LINKS} svhdesc builds (its collision probes test every pair of bodies: "
        "the time grows with the square of the links)"
    )


def depth_problem(parent_of: Mapping[str, str]) -> str | None:
    """Why a tree is too deep for svhdesc to build, or None."""
    depth = tree_depth(parent_of)
    if depth <= MAX_DEPTH:
        return None
    return (
        f"its tree is {depth} links deep, more than the {MAX_DEPTH} svhdesc builds and simulates (a body nested in "
        "its parent's for every link)"
    )
