"""Command-line interface. No physics here: each command parses arguments and calls one function."""

from __future__ import annotations

import sys
from pathlib import Path

import click

from impactsim.case import CaseError

SET_HELP = "Override a case key, TOML value syntax: --set run.cfl=0.5 --set 'contact.passes=[\"node-face\"]'"


def _load(case_file: str, overrides: tuple[str, ...]):
    from impactsim.case import load_case

    return load_case(Path(case_file), overrides)


def _fail(err: Exception) -> None:
    click.echo(f"error: {err}", err=True)
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

    try:
        case = _load(case_file, overrides)
        click.echo(describe_case(case))
    except CaseError as err:
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
    except CaseError as err:
        _fail(err)


@main.command()
@click.argument("case_file", type=click.Path(dir_okay=False))
@click.option("-o", "--out", "out_dir", type=click.Path(file_okay=False), default=None,
              help="Output folder (default: out/<case name>/).")
@click.option("--set", "overrides", multiple=True, metavar="KEY=VALUE", help=SET_HELP)
@click.option("-q", "--quiet", is_flag=True, help="No progress output.")
def run(case_file: str, out_dir: str | None, overrides: tuple[str, ...], quiet: bool) -> None:
    """Run CASE_FILE and write a VTU time series, history.csv and summary.json."""
    from impactsim.solver.run import SimulationError, run_case

    try:
        case = _load(case_file, overrides)
        result = run_case(case, Path(out_dir) if out_dir else None, progress=not quiet)
    except (CaseError, SimulationError) as err:
        _fail(err)
    if result.get("stopped"):
        click.echo(f"stopped: {result['stopped']}", err=True)
        sys.exit(3)


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
    except (SweepError, CaseError) as err:
        _fail(err)


if __name__ == "__main__":  # pragma: no cover
    main()
