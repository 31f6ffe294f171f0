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
@click.option("-q", "--quiet", is_flag=True, help="No progress output.")
@click.option("--workers", type=int, default=None, help="quasistatic: worker processes (0: none).")
@click.option("--scheduler", default=None, metavar="ADDRESS", help="quasistatic: Dask scheduler.")
def run(case_file: str, out_dir: str | None, overrides: tuple[str, ...], quiet: bool,
        workers: int | None, scheduler: str | None) -> None:
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

            out = Path(out_dir) if out_dir else None
            if isinstance(case, QSCase):
                from impactsim.quasistatic.run import run_quasistatic

                result = run_quasistatic(case, out, workers, scheduler, not quiet)
            else:
                result = run_case(case, out, progress=not quiet)
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
def render(run_dir: str, field: str, every: int) -> None:
    """Render the frames of a finished run to PNG images (off-screen, pyvista)."""
    from impactsim.output.render import RenderError, render_series

    try:
        for path in render_series(Path(run_dir), field=field, every=every):
            click.echo(str(path))
    except RenderError as err:
        _fail(err)


@main.command()
def warmup() -> None:
    """Compile every numba kernel into the on-disk cache (make setup runs this once)."""
    from impactsim.warmup import main as warm

    warm()


if __name__ == "__main__":  # pragma: no cover
    main()
