"""The consumers' table: every variant's MJCF, URDF and USD in the engines people simulate in, against MuJoCo C.

    python benchmarks/consumers.py [--variants svh_right,...] [--out docs/results]

For each variant and each engine, in the environment that engine needs (its own interpreter: MuJoCo 3.17 and Newton's
SolverMuJoCo in .venv-newton, MuJoCo 3.11 in .venv-mjlab, Newton's own solvers beside MuJoCo 4 in .venv): does it
load, how many degrees of freedom, how many of the spec's couplings it keeps, the mass, and one second of the same
servo targets (60 % of each channel's range, gravity and contacts off) against MuJoCo C on the MJCF: the largest
joint gap over the run and at its end, and the largest coupling residual. Then the same engines on broken copies of
the files (a USD cut short, an MJCF coupling of a joint that does not exist, a URDF joint whose child link does not
exist): each gets one
line naming the engine, the file and its reason. Writes docs/results/consumers.md.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from dataclasses import dataclass
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
import results  # noqa: E402

import svhdesc  # noqa: E402
from svhdesc.loaders import couplings  # noqa: E402
from svhdesc.loaders.newton import model_file  # noqa: E402
from svhdesc.loaders.track import Run, compare, run_in, servo_plan  # noqa: E402

REPO = Path(__file__).resolve().parents[1]


@dataclass(frozen=True)
class Consumer:
    label: str
    engine: str  # what svhdesc.loaders.track runs: mujoco, mjlab or newton
    python: str  # the interpreter of its environment
    files: tuple[str, ...]
    solver: str = "featherstone"


CONSUMERS = (
    Consumer("MuJoCo C (reference)", "mujoco", sys.executable, ("mjcf",), "MuJoCo C"),
    Consumer("MuJoCo 3.17 (Newton's pin)", "mujoco", str(REPO / ".venv-newton/bin/python"), ("mjcf",), "MuJoCo C"),
    Consumer("MuJoCo 3.11 (mjlab's pin)", "mujoco", str(REPO / ".venv-mjlab/bin/python"), ("mjcf",), "MuJoCo C"),
    Consumer("Newton", "newton", sys.executable, ("usd", "mjcf", "urdf"), "featherstone"),
    Consumer("Newton", "newton", str(REPO / ".venv-newton/bin/python"), ("usd", "mjcf", "urdf"), "mujoco"),
    # mjlab's entity (svhdesc.mjlab: the variant's batch model, mjlab's solver options) compiled by mjlab
    Consumer(
        "mjlab 1.6 (svhdesc.mjlab's entity)", "mjlab", str(REPO / ".venv-mjlab/bin/python"), ("mjcf",), "MuJoCo C"
    ),
)
SOLVERS = {"featherstone": "Featherstone (Warp CPU)", "mujoco": "SolverMuJoCo (MuJoCo C 3.17)", "MuJoCo C": "-"}
COLUMNS = (
    "variant",
    "engine",
    "version",
    "solver",
    "file",
    "loads",
    "DoF",
    "couplings kept",
    "mass kg",
    "max gap to MuJoCo C, rad",
    "gap at 1 s, rad",
    "coupling residual, rad",
)


def spec(variant: str) -> list[tuple[str, str, float, float]]:
    return [(c.joint, c.leader, c.offset, c.multiplier) for c in couplings(variant)]


def row(variant: str, consumer: Consumer, run: Run, reference: Run) -> list[str]:
    head = [f"`{variant}`", consumer.label, run.version, SOLVERS[consumer.solver], run.file]
    if run.error:
        return [*head, f"no: {run.error}", *["-"] * (len(COLUMNS) - 6)]
    figures = compare(reference, run, spec(variant))
    change = 100 * (run.mass / reference.mass - 1)
    mass = f"{run.mass:.4f} ({change if abs(change) >= 5e-4 else 0.0:+.3f} %)"  # no "-0.000"
    kept = f"{figures.mimics_kept} of {len(spec(variant))}"
    gaps = [f"{figures.deviation:.2g}", f"{figures.final:.2g}", f"{figures.residual:.1e}"]
    return [*head, "yes", str(run.dof), kept, mass, *gaps]


def variant_rows(variant: str) -> list[list[str]]:
    mjcf = str(svhdesc.get(variant).mjcf_path)
    plan = servo_plan(mjcf)
    reference = run_in(sys.executable, "mujoco", "mjcf", mjcf, plan)
    if reference.error:
        raise SystemExit(f"error: MuJoCo C cannot run {mjcf}: {reference.error}")
    rows = []
    for consumer in CONSUMERS:
        for file in consumer.files:
            path = model_file(variant, file)
            run = run_in(consumer.python, consumer.engine, file, path, plan, consumer.solver)
            rows.append(row(variant, consumer, run, reference))
            print(" | ".join(rows[-1]), flush=True)
    return rows


def broken_files(folder: Path, variant: str) -> dict[str, Path]:
    """Copies of the variant's files that no engine should read: the USD cut in half, an MJCF coupling (joint
    equality) of a joint that does not exist, a URDF joint whose child link does not exist."""
    model = svhdesc.get(variant)
    usd = model.usd_path.read_text()
    mjcf = model.mjcf_path.read_text().replace(' joint1="', ' joint1="no_such_', 1)
    mjcf = mjcf.replace('meshdir="assets"', f'meshdir="{model.directory / "assets"}"')
    urdf = model.absolute_urdf_path().read_text()
    child = urdf.index('<child link="') + len('<child link="')
    texts = {
        "usd": ("cut.usda", usd[: len(usd) // 2]),
        "mjcf": ("coupling_to_nothing.xml", mjcf),
        "urdf": ("missing_link.urdf", urdf[:child] + "no_such_link" + urdf[urdf.index('"', child) :]),
    }
    for name, text in texts.values():
        (folder / name).write_text(text)
    return {file: folder / name for file, (name, _) in texts.items()}


def as_variant(mjcf: Path) -> Path:
    """The broken MJCF as a built variant's folder holds it (model and batch model), which mjlab's entity reads."""
    folder = mjcf.parent / mjcf.stem
    folder.mkdir(exist_ok=True)
    for name in (f"{mjcf.stem}.xml", f"{mjcf.stem}_batch.xml"):
        (folder / name).write_text(mjcf.read_text())
    return folder / f"{mjcf.stem}.xml"


def bad_input_rows(variant: str) -> list[list[str]]:
    plan = servo_plan(str(svhdesc.get(variant).mjcf_path))
    rows = []
    with tempfile.TemporaryDirectory() as folder:
        broken = broken_files(Path(folder), variant)
        for consumer in CONSUMERS:
            for file in consumer.files:
                path = as_variant(broken[file]) if consumer.engine == "mjlab" else broken[file]
                run = run_in(consumer.python, consumer.engine, file, str(path), plan, consumer.solver)
                verdict = f"no: {run.error}" if run.error else "yes (a broken file was read)"
                rows.append(
                    [consumer.label, run.version, SOLVERS[consumer.solver], f"{file}: {broken[file].name}", verdict]
                )
    return rows


def table(columns: tuple[str, ...] | list[str], rows: list[list[str]]) -> list[str]:
    lines = ["| " + " | ".join(columns) + " |", "|" + "---|" * len(columns)]
    return lines + ["| " + " | ".join(cell.replace("|", "/") for cell in r) + " |" for r in rows]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    everything = sorted(svhdesc.variants(), key=lambda name: (name != "svh_right", name))
    parser.add_argument("--variants", default=",".join(everything), help="the first also gets the broken files")
    parser.add_argument("--out", type=Path, default=None, help="folder for consumers.md (default docs/results)")
    args = parser.parse_args()
    first, *others = args.variants.split(",")
    body = [
        *table(COLUMNS, variant_rows(first)),
        "",
        f"Broken copies of `{first}`'s files, each engine in its own environment:",
        "",
        *table(["engine", "version", "solver", "file", "loads"], bad_input_rows(first)),
    ]
    for variant in others:
        body += ["", f"`{variant}`:", "", *table(COLUMNS, variant_rows(variant))]
    path = results.write(
        "consumers", "The models in other engines and MuJoCo versions, against MuJoCo C", body, args.out
    )
    print(f"wrote {path}")


if __name__ == "__main__":
    main()
