"""Command-line interface. No physics here: each command parses arguments and calls one function."""

from __future__ import annotations

import sys
from pathlib import Path

import click

SET_HELP = "Override a case key, TOML value syntax: --set run.cfl=0.5 --set 'contact.passes=[\"node-face\"]'"


def _case_error():
    from impactsim.case import CaseError

    return CaseError


def _load(case_file: str, overrides: tuple[str, ...]):
    from impactsim.case import load_case
    from impactsim.case.quasistatic import is_quasistatic, load_quasistatic

    if is_quasistatic(case_file, overrides):
        return load_quasistatic(Path(case_file), overrides)
    return load_case(Path(case_file), overrides)


def _fail(err: Exception) -> None:
    click.echo("error: " + " ".join(str(err).split("\n")), err=True)  # one line, always
    sys.exit(2)


@click.group(context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(package_name="impactsim")
def main() -> None:
    """impactsim: explicit simulation of high-velocity impact between solid bodies."""
    from impactsim.kernel_cache import refresh

    refresh()  # cached kernels compiled from older sources go (impactsim/kernel_cache.py)


@main.command()
@click.argument("case_file", type=click.Path(dir_okay=False))
@click.option("--set", "overrides", multiple=True, metavar="KEY=VALUE", help=SET_HELP)
def check(case_file: str, overrides: tuple[str, ...]) -> None:
    """Validate CASE_FILE and print the resolved case and what would run."""
    from impactsim.case.describe import describe_case
    from impactsim.case.quasistatic import QSCase, describe_quasistatic

    try:
        case = _load(case_file, overrides)
        click.echo((describe_quasistatic if isinstance(case, QSCase) else describe_case)(case))
    except _case_error() as err:
        _fail(err)


@main.command()
@click.argument("case_file", type=click.Path(dir_okay=False))
@click.option("-o", "--out", "out_dir", type=click.Path(file_okay=False), default=None,
              help="Output folder (default: out/<case name>/).")
@click.option("--set", "overrides", multiple=True, metavar="KEY=VALUE", help=SET_HELP)
def mesh(case_file: str, out_dir: str | None, overrides: tuple[str, ...]) -> None:
    """Mesh the bodies of CASE_FILE, write their VTU and print a quality report."""
    from impactsim.mesh.report import mesh_case

    try:
        case = _load(case_file, overrides)
        click.echo(mesh_case(case, Path(out_dir) if out_dir else None))
    except _case_error() as err:
        _fail(err)


@main.command()
@click.argument("case_file", type=click.Path(dir_okay=False))
@click.option("-o", "--out", "out_dir", type=click.Path(file_okay=False), default=None,
              help="Output folder (default: out/<case name>/).")
@click.option("--set", "overrides", multiple=True, metavar="KEY=VALUE", help=SET_HELP)
@click.option("-q", "--quiet", is_flag=True, help="Only warnings and errors.")
@click.option("--overwrite", is_flag=True, help="Replace an earlier run's outputs in the folder.")
@click.option("--resume", "resume_dir", type=click.Path(file_okay=False), default=None,
              help="Continue the run in this folder from its last checkpoint.")
@click.option("--workers", type=int, default=None, help="quasistatic: worker processes (0: none).")
@click.option("--scheduler", default=None, metavar="ADDRESS", help="quasistatic: Dask scheduler.")
def run(case_file: str, out_dir: str | None, overrides: tuple[str, ...], quiet: bool,
        overwrite: bool, resume_dir: str | None, workers: int | None,
        scheduler: str | None) -> None:
    """Run CASE_FILE and write a VTU time series, history.csv and summary.json.

    Exit codes: 0 finished, 2 bad input (case, mesh, output folder), 3 stopped before the end
    time (SIGTERM, Ctrl-C, a failed check, a non-finite state; summary.json says why)."""
    from impactsim.solver.stop import EXIT_STOPPED, RunStopped, StopSignals, stopped_early

    stops = StopSignals.install()  # SIGTERM / Ctrl-C from here on stop the run cleanly
    stops.urgent = False  # while the case is read, a signal waits (then the folder is known)
    case = None
    try:
        try:
            case = _load(case_file, overrides)
            stops.raise_if_requested()
            from impactsim.case.quasistatic import QSCase
            from impactsim.solver.run import run_case

            folder = resume_dir or out_dir
            out = Path(folder) if folder else None
            if isinstance(case, QSCase):
                from impactsim.quasistatic.run import run_quasistatic

                result = run_quasistatic(case, out, workers, scheduler, not quiet)
            else:
                result = run_case(case, out, progress=not quiet, overwrite=overwrite,
                                  resume=resume_dir is not None)
        except Exception as err:
            from impactsim.solver.run import SimulationError

            if isinstance(err, (_case_error(), SimulationError)):
                _fail(err)
            raise
    except RunStopped as err:  # while starting up: a summary with the reason, if it can
        click.echo(f"stopped: {stopped_early(case, out_dir, err, stops)}", err=True)
        sys.exit(EXIT_STOPPED)
    finally:
        stops.uninstall()
    if result.get("stopped"):
        click.echo(f"stopped: {result['stopped']}", err=True)
        sys.exit(EXIT_STOPPED)


@main.command()
@click.argument("run_dir", type=click.Path(file_okay=False, exists=True))
@click.option("--field", default="von_mises", show_default=True, help="Cell or point field to colour by.")
@click.option("--every", default=1, show_default=True, help="Render every N-th frame.")
@click.option("-o", "--out", "out_dir", type=click.Path(file_okay=False), default=None,
              help="Folder of the PNGs (default: RUN_DIR/render/).")
@click.option("--slice", "cut", default=None, metavar="NORMAL[,POINT]",
              help="Cut the bodies and look at the cut: --slice y, --slice 0,1,0,0,0,0.001.")
@click.option("--view", type=click.Choice(["impact", "all"]), default="impact", show_default=True,
              help="Frame the impact region or every body.")
@click.option("--no-particles", is_flag=True, help="Do not draw the particles.")
@click.option("--animate", default=None, metavar="OUT.mp4|OUT.gif", help="Also an animation.")
@click.option("--fps", default=4.0, show_default=True, help="Frames per second of --animate.")
@click.option("--size", nargs=2, type=int, default=(1024, 768), show_default=True,
              help="Image width and height in pixels.")
def render(run_dir: str, field: str, every: int, out_dir, cut, view, no_particles, animate, fps,
           size) -> None:
    """Render the frames of a finished run to PNG images (off-screen, pyvista)."""
    from impactsim.output.render import RenderError, parse_cut, render_series

    try:
        for path in render_series(Path(run_dir), field=field, every=every, out=out_dir,
                                  cut=parse_cut(cut), view=view, particles=not no_particles,
                                  animate=animate, fps=fps, window_size=tuple(size)):
            click.echo(str(path))
        if animate:
            click.echo(animate)
    except RenderError as err:
        _fail(err)


@main.command()
@click.option("--workers", type=int, default=None,
              help="Processes compiling at once (default: the cores, at most 2).")
def warmup(workers: int | None) -> None:
    """Compile every numba kernel into the on-disk cache (make setup runs this once)."""
    from impactsim.warmup import main as warm

    warm([] if workers is None else ["--workers", str(workers)])


@main.command()
@click.argument("run_dir", type=click.Path(file_okay=False, exists=True))
@click.option("-o", "--out", "out_file", type=click.Path(dir_okay=False), default=None,
              help="The PNG (default: RUN_DIR/history.png).")
def plot(run_dir: str, out_file: str | None) -> None:
    """Plot history.csv: energy terms and balance, contact force, body velocities, particles."""
    from impactsim.output.plot import PlotError, plot_history

    try:
        click.echo(str(plot_history(Path(run_dir), Path(out_file) if out_file else None)))
    except PlotError as err:
        _fail(err)


@main.command()
@click.argument("name", required=False)
def materials(name: str | None) -> None:
    """List the material library with sources, or show one entry (all its values)."""
    from impactsim.materials.listing import MaterialError, describe, listing

    try:
        click.echo(describe(name) if name else listing())
    except MaterialError as err:
        _fail(err)


@main.command()
@click.argument("sweep_file", type=click.Path(dir_okay=False))
@click.option("-o", "--out", "out_dir", type=click.Path(file_okay=False), default=None,
              help="Output folder (default: out/sweeps/<sweep name>/).")
@click.option("--scheduler", default=None, metavar="ADDRESS",
              help="Run on an existing Dask cluster (tcp://host:8786) instead of a local one.")
@click.option("--workers", type=int, default=None,
              help="Local worker processes (default: one per core; 0: in this process).")
def sweep(sweep_file: str, out_dir: str | None, scheduler: str | None, workers: int | None) -> None:
    """Run the variants of SWEEP_FILE on Dask; results.csv / results.parquet list them."""
    from impactsim.studies.sweep import SweepError, run_sweep

    try:
        run_sweep(Path(sweep_file), Path(out_dir) if out_dir else None, scheduler, workers)
    except (SweepError, _case_error()) as err:
        _fail(err)


@main.command("ballistic-limit")
@click.argument("case_file", type=click.Path(dir_okay=False))
@click.option("--vary", required=True, metavar="KEY", help="The key searched, e.g. body.sphere.radius.")
@click.option("--range", "range_", nargs=2, required=True, metavar="LO HI",
              help="Where to search, e.g. --range '2 mm' '8 mm'.")
@click.option("--at", "at", required=True, metavar="KEY=V1,V2,...",
              help="One limit per value, e.g. --at 'body.sphere.speed=2 km/s,3 km/s'.")
@click.option("--tol", required=True, help="Width of the final bracket, in the unit of --range.")
@click.option("--plate", default=None, help="Perforated: a hole through this plate "
              "(default: the case's last body of shape plate).")
@click.option("--residual-speed", default=None, metavar="SPEED", help="Perforated instead: the "
              "residual speed of --body above SPEED (m/s).")
@click.option("--body", default=None, help="The body of --residual-speed.")
@click.option("--reference", type=click.Path(dir_okay=False, exists=True), default=None,
              help="A CSV curve (first two columns) drawn under the result.")
@click.option("-o", "--out", "out_dir", type=click.Path(file_okay=False), default=None,
              help="Output folder (default: out/ballistic/<case name>/).")
@click.option("--scheduler", default=None, metavar="ADDRESS", help="An existing Dask cluster.")
@click.option("--workers", type=int, default=None, help="Local workers (0: in this process).")
@click.option("--set", "overrides", multiple=True, metavar="KEY=VALUE", help=SET_HELP)
def ballistic_limit(case_file, vary, range_, at, tol, plate, residual_speed, body, reference,
                    out_dir, scheduler, workers, overrides) -> None:
    """Find, per value of --at, the value of --vary at which the plate is just perforated."""
    from impactsim.studies.ballistic import Criterion, ballistic_limit, parse_at, speed_threshold
    from impactsim.studies.sweep import SweepError

    try:
        crit = Criterion("residual", body, speed_threshold(residual_speed)) \
            if residual_speed is not None else Criterion("hole", plate)
        key, values = parse_at(at)
        ballistic_limit(Path(case_file), vary, *range_, key, values, tol, crit,
                        Path(out_dir) if out_dir else None, scheduler, workers, overrides,
                        Path(reference) if reference else None)
    except (SweepError, _case_error()) as err:
        _fail(err)


if __name__ == "__main__":  # pragma: no cover
    main()
