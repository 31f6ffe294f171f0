"""docs/accuracy.md and docs/accuracy/<study>.png from the runs of `make accuracy`.

``analyse(study, runs)`` turns one study's runs into error columns and fitted orders;
``write_report(studies, runs, meta)`` writes the markdown (tables of elements, steps, wall
seconds, values and errors; a table of observed orders) and one figure per study with a log-log
panel of error against wall seconds per measured quantity (matplotlib, Agg backend).
"""

from __future__ import annotations

import math
import platform
from dataclasses import dataclass, field
from datetime import datetime, timezone
from pathlib import Path

from benchmarks.accuracy_fit import (errors_vs_finest, fit_power, order_vs_finest,
                                     relative_error, richardson_order)
from benchmarks.accuracy_studies import ROOT, Study

DOC = ROOT / "docs" / "accuracy.md"
FIG_DIR = ROOT / "docs" / "accuracy"
COMMAND = "make accuracy"
MIN_RATE = 0.05  # q below this: the error does not fall with cost (converged, or a floor)
P_SHOWN = (0.2, 8.0)  # a Richardson order outside this range gives no useful extrapolation


@dataclass
class ErrorColumn:
    """The errors of one quantity of one series against one reference, with fitted rates."""
    series: str
    quantity: str
    reference: str  # "exact" or "finest"
    absolute: bool  # error in the quantity's unit (exact value 0) rather than relative
    unit: str
    errors: list[float]  # per run, coarse to fine (the finest is 0 against itself)
    order: float | None  # p of error = C x^p
    rate: float | None  # q of error = C wall^-q
    x: list[float] = field(default_factory=list)
    wall: list[float] = field(default_factory=list)
    floor: float = 0.0  # absolute errors up to this count as none (same unit as errors)

    def at_floor(self) -> bool:
        """Every error is below the floor: nothing to converge."""
        return self.floor > 0 and all(e <= self.floor for e in self.errors)


@dataclass
class SeriesFit:
    series: str
    quantity: str
    richardson: tuple[float, float] | None  # (p, extrapolated value) from the three finest
    theory: float | None  # a simpler theory's value (unscaled)
    exact: float | None  # the analytic value (unscaled)
    finest: float  # the finest run's value (unscaled)
    unit: str
    scale: float


def _series_runs(runs: list[dict], study: Study) -> dict[str, list[dict]]:
    out = {}
    for name in study.series:
        rs = sorted((r for r in runs if r["study"] == study.key and r["series"] == name),
                    key=lambda r: r["level"])
        if rs:
            out[name] = rs
    return out


def analyse(study: Study, runs: list[dict]) -> tuple[list[ErrorColumn], list[SeriesFit]]:
    columns, fits = [], []
    for name, rs in _series_runs(runs, study).items():
        x = [r["x"] for r in rs]
        wall = [r["wall_seconds"] for r in rs]
        for qname, q0 in rs[0]["quantities"].items():
            values = [r["quantities"][qname]["value"] for r in rs]
            exact = q0["exact"]
            unit, scale = q0["unit"], q0["scale"]
            if exact is not None:
                absolute = exact == 0
                err = [relative_error(v, exact) * (scale if absolute else 1.0) for v in values]
                p = fit_power(x, err)
                q = fit_power(wall, err)
                floor = q0.get("floor", 0.0) * scale if absolute else 0.0
                columns.append(ErrorColumn(name, qname, "exact", absolute,
                                           unit if absolute else "", err,
                                           p[0] if p else None, -q[0] if q else None, x, wall,
                                           floor))
            if exact is None or study.vs_finest:
                err = errors_vs_finest(values)
                p = order_vs_finest(x, values)
                q = fit_power(wall[:-1], err[:-1])
                columns.append(ErrorColumn(name, qname, "finest", False, "", err,
                                           p[0] if p else None, -q[0] if q else None, x, wall))
            fits.append(SeriesFit(name, qname, richardson_order(x, values), q0["theory"],
                                  exact, values[-1], unit, scale))
    return columns, fits


def _num(v: float | None, digits: int = 4) -> str:
    if v is None or (isinstance(v, float) and not math.isfinite(v)):
        return "–"
    return f"{v:.{digits}g}"


def _err(col: ErrorColumn, i: int) -> str:
    e = col.errors[i]
    if col.reference == "finest" and i == len(col.errors) - 1:
        return "(ref.)"
    if col.absolute:
        return f"{e:.3g}"
    return f"{100 * e:.3g} %"


def _x_text(study: Study, x: float) -> str:
    return f"{x * 1e3:.4g}" if study.x_name == "h" else f"{x:g}"


def _err_header(col: ErrorColumn) -> str:
    what = "abs. error" + (f" [{col.unit}]" if col.unit else "") if col.absolute else "error"
    return f"{col.quantity} {what} vs {col.reference}"


def _shown(columns: list[ErrorColumn], quantity: str, series: str) -> list[ErrorColumn]:
    """The error columns of the runs table (an error against an exact 0 is the value itself)."""
    return [c for c in columns if c.quantity == quantity and c.series == series
            and not c.absolute]


def falls(col: ErrorColumn) -> bool:
    """The error falls with cost at a measurable rate, and the dearest run beats the cheapest."""
    last = len(col.errors) - (2 if col.reference == "finest" else 1)
    return (col.rate is not None and col.rate > MIN_RATE and last > 0
            and col.errors[last] < col.errors[0])


def verdict(col: ErrorColumn) -> str:
    if col.at_floor():
        return f"none left (≤ {col.floor:g} {col.unit} at every level)"
    return "yes" if falls(col) else "no"


def runs_table(study: Study, runs: list[dict], columns: list[ErrorColumn]) -> list[str]:
    series = _series_runs(runs, study)
    first = next(iter(series.values()))
    qnames = list(first[0]["quantities"])
    xh = "h [mm]" if study.x_name == "h" else "CFL"
    head = ["series", xh, "elements", "steps", "wall s", "CPU s"]
    for qn in qnames:
        q0 = first[0]["quantities"][qn]
        head.append(f"{qn}" + (f" [{q0['unit']}]" if q0["unit"] else ""))
        head += [_err_header(c) for c in _shown(columns, qn, first[0]["series"])]
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for name, rs in series.items():
        cols = [c for c in columns if c.series == name]
        for i, r in enumerate(rs):
            row = [name, _x_text(study, r["x"]), f"{r['elements']:,}", f"{r['steps']:,}",
                   f"{r['wall_seconds']:.2f}",
                   f"{r['cpu_seconds']:.2f}" if "cpu_seconds" in r else "–"]
            for qn in qnames:
                q = r["quantities"][qn]
                row.append(_num(q["value"] * q["scale"], 5))
                row += [_err(c, i) for c in _shown(cols, qn, name)]
            if r.get("stopped"):
                row[0] += " (stopped)"
            lines.append("| " + " | ".join(row) + " |")
    return lines


def orders_table(study: Study, columns: list[ErrorColumn], fits: list[SeriesFit]) -> list[str]:
    xs = "h" if study.x_name == "h" else "CFL"
    lines = [f"| series | quantity | reference | order p (error ∝ {xs}^p, least squares) | "
             "p from the 3 finest (Richardson) | extrapolated | rate q (error ∝ wall^-q) | "
             "1-D theory: finest run's deviation |", "|---|---|---|---|---|---|---|---|"]
    for c in columns:
        fit = next(f for f in fits if f.series == c.series and f.quantity == c.quantity)
        rich = fit.richardson
        p3 = _num(rich[0], 3) if rich else "not monotone"
        extra = "–"
        if rich and P_SHOWN[0] <= rich[0] <= P_SHOWN[1] and fit.exact != 0:
            extra = _num(rich[1] * fit.scale, 5) + (f" {fit.unit}" if fit.unit else "")
        theory = "–"
        if fit.theory:
            theory = (f"{_num(fit.theory * fit.scale, 4)} {fit.unit}: "
                      f"{100 * (fit.finest - fit.theory) / fit.theory:+.2f} %")
        lines.append(f"| {c.series} | {c.quantity} | {c.reference} | {_num(c.order, 3)} | {p3} "
                     f"| {extra} | {_num(c.rate, 3)} | {theory} |")
    return lines


def _err_text(col: ErrorColumn, e: float) -> str:
    return f"{e:.3g} {col.unit}".strip() if col.absolute else f"{100 * e:.3g} %"


def findings(study: Study, runs: list[dict], columns: list[ErrorColumn]) -> list[str]:
    """Generated sentences: each error from the cheapest to the dearest run that has one, and
    the cost of each series against the first."""
    lines = []
    for c in columns:
        last = len(c.errors) - (2 if c.reference == "finest" else 1)
        if last < 1:
            continue
        if c.at_floor():
            lines.append(f"- {c.series}, {c.quantity} vs {c.reference}: at most "
                         f"{_err_text(c, max(c.errors))} at every level, below what the measure "
                         f"resolves (≤ {c.floor:g} {c.unit}): nothing left to converge.")
            continue
        verdict = "falls" if falls(c) else "does not fall with cost"
        lines.append(f"- {c.series}, {c.quantity} vs {c.reference}: {_err_text(c, c.errors[0])} "
                     f"at {c.wall[0]:.3g} s, {_err_text(c, c.errors[last])} at "
                     f"{c.wall[last]:.3g} s: {verdict} (q = {_num(c.rate, 2)}, "
                     f"p = {_num(c.order, 2)}).")
    series = _series_runs(runs, study)
    names = list(series)
    for name in names[1:]:  # over the levels both series ran
        common = {r["level"] for r in series[name]} & {r["level"] for r in series[names[0]]}
        a = [r for r in series[names[0]] if r["level"] in common]
        b = [r for r in series[name] if r["level"] in common]
        wall = sum(r["wall_seconds"] for r in b) / max(sum(r["wall_seconds"] for r in a), 1e-12)
        steps = sum(r["steps"] for r in b) / max(sum(r["steps"] for r in a), 1)
        lines.append(f"- cost: {name} takes {wall:.2f} times the wall seconds of {names[0]} "
                     f"over the levels both ran ({steps:.2f} times the steps).")
    return lines


def plot_study(study: Study, columns: list[ErrorColumn], path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.ticker import NullFormatter

    qnames = list(dict.fromkeys(c.quantity for c in columns))
    fig, axes = plt.subplots(1, len(qnames), figsize=(4.2 * len(qnames), 3.8), squeeze=False)
    markers = "osD^v<>"
    for ax, qn in zip(axes[0], qnames):
        cols = [c for c in columns if c.quantity == qn]
        for k, c in enumerate(cols):
            pts = [(w, e) for j, (w, e) in enumerate(zip(c.wall, c.errors))
                   if e > 0 and not (c.reference == "finest" and j == len(c.errors) - 1)]
            if not pts:
                continue
            w, e = zip(*pts)
            rate = f", q = {c.rate:.2f}" if c.rate is not None else ""
            ax.loglog(w, e, marker=markers[k % len(markers)], label=f"{c.series} vs {c.reference}"
                      f"{rate}")
        absolute = cols[0].absolute
        unit = f" [{cols[0].unit}]" if cols[0].unit else ""
        ax.set_ylabel(f"{qn} error{unit}" if absolute else f"{qn}: relative error")
        ax.set_xlabel("wall seconds")
        for axis, lim in ((ax.xaxis, ax.get_xlim()), (ax.yaxis, ax.get_ylim())):
            if lim[1] > 10 * lim[0]:  # a decade or more: labels at decades (minor ones overlap)
                axis.set_minor_formatter(NullFormatter())
        ax.tick_params(which="both", labelsize=7)
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=7)
        ax.set_title(qn, fontsize=9)
    fig.suptitle(study.title, fontsize=10)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=90, metadata={"Software": None})  # no version string: stable files
    plt.close(fig)


def write_report(studies: list[Study], runs: list[dict], meta: dict) -> Path:
    import numba
    import numpy as np

    elapsed = meta.get("elapsed")
    lines = [
        "# Accuracy against cost",
        "",
        f"<!-- Generated by `{COMMAND}` (python benchmarks/accuracy.py); do not edit by hand. "
        "`python benchmarks/accuracy.py --report-only` rewrites it from out/accuracy/"
        "results.json. -->",
        "",
        f"Generated by `{COMMAND}` on {datetime.now(timezone.utc):%Y-%m-%d} "
        f"({meta.get('cpus', '?')} cores, {meta.get('jobs', '?')} runs at a time, one numba "
        f"thread each; Python {platform.python_version()}, numpy {np.__version__}, numba "
        f"{numba.__version__})" + (f": {elapsed / 60:.1f} minutes in all." if elapsed else "."),
        "",
        "Each study runs a bundled case at several levels of one parameter (mesh size, Courant "
        "number, element formulation, contact passes) through `impactsim.case.load_case(path, "
        "overrides=[...])` and `run_case`. Errors are against an analytic value ('exact') where "
        "the problem has one, else against the finest run of the same series ('finest'). "
        "'wall s' is the run's wall time without meshing (meshes are cached); the machine is "
        "shared, so these carry its load (runs under two seconds are repeated and the fastest "
        "time kept); 'CPU s' is the run's process time, which the other load inflates far less. "
        "Fitted rates:",
        "",
        "- order p: least-squares fit of error = C x^p over the runs (x = mesh size h or CFL "
        "number; against 'finest' over the runs coarser than the finest, which makes p high "
        "when the finest run is not much finer);",
        "- p from the 3 finest: the order observed on the three finest runs with the "
        "extrapolated value (Richardson; Celik et al. 2008 for unequal ratios), when they "
        "change monotonically;",
        "- rate q: least-squares fit of error = C wall^-q: how fast the error falls as the "
        "wall time goes up. Mesh refinement costs about h^-4 in 3-D (h^-3 elements, h^-1 "
        "steps), so q ≈ p / 4 there; the 1-D column costs h^-2 (q ≈ p / 2).",
        "",
        "## Summary",
        "",
        f"'falls with cost' is yes where the rate q exceeds {MIN_RATE} and the dearest run's "
        "error is below the cheapest's; where it is no, the study's text says why (a quantity "
        "converged at every level, or held at a floor the discretisation does not control).",
        "",
        "| study | series | quantity | reference | order p | rate q | falls with cost |",
        "|---|---|---|---|---|---|---|",
    ]
    body = []
    for study in studies:
        if not any(r["study"] == study.key for r in runs):
            continue
        columns, fits = analyse(study, runs)
        png = FIG_DIR / f"{study.key}.png"
        plot_study(study, columns, png)
        for c in columns:
            lines.append(f"| [{study.key}](#{study.key}) | {c.series} | {c.quantity} | "
                         f"{c.reference} | {_num(c.order, 3)} | {_num(c.rate, 3)} | "
                         f"{verdict(c)} |")
        seconds = sum(r["wall_seconds"] for r in runs if r["study"] == study.key)
        body += ["", f"<a id=\"{study.key}\"></a>", f"## {study.title}", "", study.about, "",
                 f"{sum(r['study'] == study.key for r in runs)} runs, {seconds:.0f} wall "
                 "seconds in all.", "",
                 f"![{study.title}](accuracy/{png.name})", ""]
        body += runs_table(study, runs, columns)
        body += ["", "Observed orders:", ""]
        body += orders_table(study, columns, fits)
        body += ["", "In short (generated from the tables):", ""]
        body += findings(study, runs, columns)
    DOC.write_text("\n".join(lines + body) + "\n")
    return DOC
