"""Which checks exist, in which order they run, and where the built variants are."""

from __future__ import annotations

import time
import traceback
from collections.abc import Callable
from pathlib import Path

from svhdesc.errors import SvhdescError
from svhdesc.validate.batch import check_batch
from svhdesc.validate.collision import check_self_collision
from svhdesc.validate.collision_fidelity import check_collision_fidelity
from svhdesc.validate.contact_stability import check_contact_stability
from svhdesc.validate.coupling import check_coupling_spec, check_limits
from svhdesc.validate.fingertip_force import check_fingertip_force
from svhdesc.validate.grasps import check_grasps
from svhdesc.validate.hold import check_gravity_hold
from svhdesc.validate.kinematics import check_kinematics
from svhdesc.validate.load_limits import check_load_limits
from svhdesc.validate.mass import check_inertia, check_mass_agreement, check_mass_budget, check_min_mass
from svhdesc.validate.options import Options
from svhdesc.validate.pair import ModelPair, load_pair
from svhdesc.validate.parsers import check_sdformat, check_urdfdom, check_yourdfpy
from svhdesc.validate.range_of_motion import check_range_of_motion
from svhdesc.validate.report import FAIL, Check, VariantReport
from svhdesc.validate.semantics import check_semantics
from svhdesc.validate.simulate import check_simulation
from svhdesc.validate.transmissions import check_transmissions
from svhdesc.validate.velocity import check_velocity_tracking

Stage = Callable[[ModelPair, Options], list[Check]]

# Each stage yields the checks named beside it (the simulation run feeds two).
STAGES: list[tuple[Stage, tuple[str, ...]]] = [
    (check_simulation, ("simulate", "coupling_tracking")),
    (check_coupling_spec, ("coupling_spec",)),
    (check_urdfdom, ("urdfdom",)),
    (check_yourdfpy, ("yourdfpy",)),
    (check_sdformat, ("sdformat",)),
    (check_kinematics, ("kinematics",)),
    (check_mass_budget, ("mass_budget",)),
    (check_inertia, ("inertia",)),
    (check_min_mass, ("min_mass",)),
    (check_mass_agreement, ("mass_agreement",)),
    (check_limits, ("limits",)),
    (check_transmissions, ("transmissions",)),
    (check_semantics, ("semantics",)),
    (check_load_limits, ("load_limits",)),
    (check_self_collision, ("self_collision",)),
    (check_gravity_hold, ("gravity_hold",)),
    (check_collision_fidelity, ("collision_fidelity",)),
    (check_range_of_motion, ("range_of_motion",)),
    (check_velocity_tracking, ("velocity_tracking",)),
    (check_contact_stability, ("contact_stability",)),
    (check_fingertip_force, ("fingertip_force",)),
    (check_grasps, ("grasps",)),
    (check_batch, ("batch",)),
]
CHECK_NAMES: tuple[str, ...] = tuple(name for _, names in STAGES for name in names)
GROUPS: dict[str, tuple[str, ...]] = {
    "parsers": ("urdfdom", "yourdfpy", "sdformat"),
    "mass": ("mass_budget", "inertia", "min_mass", "mass_agreement"),
    "coupling": ("coupling_tracking", "coupling_spec", "limits"),
    "margins": ("coupling_tracking", "load_limits"),
    "fidelity": ("collision_fidelity", "range_of_motion", "velocity_tracking", "fingertip_force", "grasps"),
}


def select_checks(requested: list[str] | tuple[str, ...]) -> set[str]:
    """Check names (or group names) -> the set to run; all of them when nothing is requested."""
    if not requested:
        return set(CHECK_NAMES)
    selected: set[str] = set()
    for item in requested:
        for name in (part.strip() for part in item.split(",")):
            if not name:
                continue
            if name in GROUPS:
                selected.update(GROUPS[name])
            elif name in CHECK_NAMES:
                selected.add(name)
            else:
                known = ", ".join([*CHECK_NAMES, *GROUPS])
                raise SvhdescError(f"unknown check '{name}' (known: {known})")
    return selected


Progress = Callable[[str], None]


def validate_pair(
    pair: ModelPair, options: Options, selected: set[str] | None = None, progress: Progress | None = None
) -> VariantReport:
    """Run the selected checks; ``progress`` is told each stage's checks as it starts, with the time so far."""
    selected = set(CHECK_NAMES) if selected is None else selected
    report = VariantReport(pair.name, str(pair.urdf_path), str(pair.mjcf_path))
    started = time.perf_counter()
    stages = [(stage, names) for stage, names in STAGES if selected.intersection(names)]
    for number, (stage, names) in enumerate(stages, 1):
        if progress is not None:
            doing = ", ".join(name for name in names if name in selected)
            progress(f"{pair.name} [{number}/{len(stages)}, {time.perf_counter() - started:.0f} s] {doing}")
        try:
            checks = stage(pair, options)
        except Exception as exc:  # a checker bug must show as a failed check, not hide the other results
            where = traceback.extract_tb(exc.__traceback__)[-1]
            checks = [
                Check(
                    name,
                    FAIL,
                    "checker error",
                    "",
                    f"{type(exc).__name__}: {exc} ({Path(where.filename).name}:{where.lineno})",
                )
                for name in names
            ]
        report.checks.extend(c for c in checks if c.name in selected)
    report.runtime_s = time.perf_counter() - started
    return report


def built_variants(out: Path, names: list[str] | tuple[str, ...]) -> list[tuple[Path, Path]]:
    """(URDF, MJCF) of each named variant under ``out`` (a name may also be a variant directory);
    every subdirectory holding <name>.xml when no name is given."""
    if not names:
        if not out.is_dir():
            raise SvhdescError(f"{out}: no such directory (build the variants first: svhdesc build)")
        found = [d for d in sorted(out.iterdir()) if d.is_dir() and (d / f"{d.name}.xml").is_file()]
        if not found:
            raise SvhdescError(f"{out}: no built variants (a variant is a folder <name>/ holding <name>.xml)")
        return [(d / f"{d.name}.urdf", d / f"{d.name}.xml") for d in found]
    pairs = []
    for name in names:
        directory = Path(name) if Path(name).is_dir() and not (out / name).is_dir() else out / name
        mjcf, urdf = directory / f"{directory.name}.xml", directory / f"{directory.name}.urdf"
        if not mjcf.is_file():
            raise SvhdescError(f"variant '{name}' is not built: {mjcf} does not exist (run: svhdesc build {name})")
        if not urdf.is_file():
            raise SvhdescError(f"variant '{name}': {urdf} does not exist")
        pairs.append((urdf, mjcf))
    return pairs


def validate_files(
    urdf: Path,
    mjcf: Path,
    options: Options,
    selected: set[str],
    config_path: Path | None = None,
    progress: Progress | None = None,
) -> VariantReport:
    return validate_pair(load_pair(urdf, mjcf, config_path=config_path), options, selected, progress)
