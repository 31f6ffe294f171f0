"""Ballistic limit: for each value of one key (typically the impact speed), the value of another
(typically the projectile's radius) at which a plate is just perforated, by bisection on the
sweep machinery (sweep.py: every run is a variant case file, run on Dask, skipped when it
finished earlier, so an interrupted search resumes where it stopped).

Perforation criterion (`Criterion`), evaluated on a run's summary.json:
- `hole` (the default): the plate body is perforated when the hole measure of
  fracture/measures.py finds a hole through its thickness: the plate's live elements projected
  onto its mid-plane leave an uncovered region not connected to the plate's border
  (`bodies.<plate>.hole.area > 0`). The default plate is the last body of the case whose shape
  is "plate" (the rear wall of a shield).
- `residual`: perforated when the residual speed of a body (its largest fragment's speed,
  `bodies.<body>.residual_speed`, or the speed of its mean velocity for a run without fracture)
  is above a threshold [m/s].

The search, per value of the second key: the two ends of the range are run first; when both
give the same outcome the limit is not bracketed and that row says so. Then each round runs k
points inside every open interval (k = 1, bisection, unless the workers outnumber the open
intervals, when the spare workers test more points at once), keeps the sub-interval where the
outcome changes, and stops when it is narrower than the tolerance. The limit reported is the
middle of the last interval, within tol/2 of the threshold of a criterion that changes once in
the range. A run that fails counts as not evaluated: its row says so and the search stops there.
"""

from __future__ import annotations

import math
import re
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from impactsim.studies.sweep import (SweepError, Variant, make_variant, run_variants, slug,
                                     variant_case, where, write_case)

_QUANTITY = re.compile(r"^\s*([-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?)\s*(.*?)\s*$")


@dataclass
class Criterion:
    kind: str = "hole"  # "hole" or "residual"
    body: str | None = None  # the plate (hole) or the projectile (residual); None: from the case
    speed: float = 0.0  # the residual-speed threshold [m/s]

    def describe(self) -> str:
        if self.kind == "hole":
            return f"a hole through plate {self.body!r}"
        return f"residual speed of {self.body!r} above {self.speed:g} m/s"

    def perforated(self, row: dict) -> bool | None:
        """The outcome of one run from its sweep row; None when the run did not give one."""
        if row.get("status") not in ("ok", "stopped"):
            return None
        if self.kind == "hole":
            val = row.get(f"{self.body}.perforated")
            return None if val is None else bool(val)
        speed = row.get(f"{self.body}.residual_speed [m/s]")
        if speed is None:
            vel = [row.get(f"{self.body}.mean_velocity_{c} [m/s]") for c in "xyz"]
            if None in vel:
                return None
            speed = math.sqrt(sum(v * v for v in vel))
        return bool(speed > self.speed)


def resolve_criterion(crit: Criterion, raw_case: dict, where_: str) -> Criterion:
    """Fill in the plate from the case: the last body of shape "plate"."""
    names = [b.get("name", f"body{i}") for i, b in enumerate(raw_case.get("body", []))]
    if crit.body is None:
        if crit.kind != "hole":
            raise SweepError(f"{where_}: a residual-speed criterion needs the body (--body)")
        plates = [b.get("name") for b in raw_case.get("body", []) if b.get("shape") == "plate"]
        if not plates:
            raise SweepError(f"{where_}: no body of shape 'plate' to perforate; name one with "
                             "--plate or use --residual-speed")
        return Criterion("hole", plates[-1], crit.speed)
    if crit.body not in names:
        raise SweepError(f"{where_}: no body {crit.body!r} (bodies: {', '.join(names)})")
    return crit


def parse_at(text: str) -> tuple[str, list]:
    """'KEY=V1,V2,...' -> (KEY, [values]); each value read as TOML, else kept as text."""
    from impactsim.case.overrides import parse_value

    if "=" not in text:
        raise SweepError(f"--at {text}: expected KEY=V1,V2,...")
    key, vals = text.split("=", 1)
    values = [parse_value(v) for v in vals.split(",") if v.strip()]
    if not values:
        raise SweepError(f"--at {text}: no values")
    return key.strip(), values


def speed_threshold(text: str) -> float:
    """--residual-speed '100 m/s' or '100' -> 100.0 [m/s]."""
    from impactsim.case.overrides import parse_value
    from impactsim.case.units import parse_quantity

    return parse_quantity(parse_value(text), "velocity", "--residual-speed")


def split_quantity(text: str, what: str) -> tuple[float, str]:
    """'3.5 mm' -> (3.5, 'mm'); '2000' -> (2000.0, '')."""
    m = _QUANTITY.match(str(text))
    if not m:
        raise SweepError(f"{what}: cannot read {text!r} as '<number> [unit]'")
    return float(m.group(1)), m.group(2)


def value_text(x: float, unit: str):
    return f"{x:.10g} {unit}" if unit else float(f"{x:.10g}")


def search(evaluate: Callable[[list[tuple[int, float]]], list[bool | None]], n_curves: int,
           lo: float, hi: float, tol: float, width: int = 1) -> list[dict]:
    """The bisection (k-section) of the module docstring over `n_curves` independent searches.
    `evaluate([(curve, x), ...])` gives each point's outcome (True: perforated, None: no
    outcome), all points of a round at once. Returns per curve {limit, lo, hi, status, runs}."""
    if not (hi > lo and tol > 0):
        raise SweepError(f"the range needs LO < HI and a tolerance > 0 (got {lo}, {hi}, {tol})")
    state = [{"lo": lo, "hi": hi, "runs": 2, "status": "searching"} for _ in range(n_curves)]
    ends = evaluate([(c, x) for c in range(n_curves) for x in (lo, hi)])
    for c in range(n_curves):
        a, b = ends[2 * c], ends[2 * c + 1]
        s = state[c]
        if a is None or b is None:
            s["status"] = "failed run"
        elif a == b:
            s["status"] = "perforated over the whole range" if a else "not perforated in the range"
        else:
            s["rising"] = b  # True: perforated at the high end
    while True:
        active = [c for c in range(n_curves) if state[c]["status"] == "searching"
                  and state[c]["hi"] - state[c]["lo"] > tol]
        if not active:
            break
        k = max(1, width // len(active))
        points = []
        for c in active:
            s = state[c]
            points += [(c, s["lo"] + (s["hi"] - s["lo"]) * (i + 1) / (k + 1)) for i in range(k)]
        got = evaluate(points)
        for j, c in enumerate(active):
            s = state[c]
            xs = [p[1] for p in points[j * k:(j + 1) * k]]
            outs = got[j * k:(j + 1) * k]
            s["runs"] += k
            if any(o is None for o in outs):
                s["status"] = "failed run"
                continue
            lo_c, hi_c = s["lo"], s["hi"]
            for x, o in zip(xs, outs):  # the first point on the perforating side closes it
                if o == s["rising"]:
                    hi_c = x
                    break
                lo_c = x
            s["lo"], s["hi"] = lo_c, hi_c
    for s in state:
        if s["status"] == "searching":
            s["status"] = "ok"
        s["limit"] = 0.5 * (s["lo"] + s["hi"]) if s["status"] == "ok" else math.nan
        s.pop("rising", None)
    return state


def ballistic_limit(case_file: Path, vary: str, lo: str, hi: str, at: str, at_values: list,
                    tol: str, criterion: Criterion | None = None, out: Path | None = None,
                    scheduler: str | None = None, workers: int | None = None,
                    overrides: tuple[str, ...] = (), reference: Path | None = None,
                    say: Callable[[str], None] = print):
    """Find the limit curve (module docstring); writes <out>/ballistic.csv, ballistic.png and
    runs.csv (every run's sweep row); returns (curve DataFrame, out folder)."""
    import tomllib

    import pandas as pd

    from impactsim.studies.cluster import default_workers, executor

    case_file = Path(case_file).resolve()
    x_lo, unit = split_quantity(lo, "--range LO")
    x_hi, unit_hi = split_quantity(hi, "--range HI")
    x_tol, unit_tol = split_quantity(tol, "--tol")
    if unit_hi != unit or unit_tol not in ("", unit):
        raise SweepError(f"--range and --tol must use one unit ({lo}, {hi}, {tol})")
    try:
        raw0 = tomllib.loads(case_file.read_text())
    except FileNotFoundError:
        raise SweepError(f"{case_file}: file not found") from None
    except tomllib.TOMLDecodeError as err:
        raise SweepError(f"{case_file}: invalid TOML: {err}") from None
    crit = resolve_criterion(criterion or Criterion(), raw0, str(case_file))
    name = raw0.get("run", {}).get("name", case_file.stem)
    folder = Path(out) if out is not None else Path("out") / "ballistic" / name
    folder.mkdir(parents=True, exist_ok=True)
    cases = folder / "runs"
    cases.mkdir(exist_ok=True)
    common = list(overrides)
    all_rows: list[dict] = []

    def evaluate_on(ex):
        def evaluate(points):
            items = []
            for c, x in points:
                values = {at: at_values[c], vary: value_text(x, unit)}
                vname = f"{at.split('.')[-1]}-{slug(at_values[c])}_{vary.split('.')[-1]}-" \
                        f"{slug(value_text(x, unit))}"
                var: Variant = make_variant(vname, common, values)
                raw = variant_case(case_file, var, str(case_file))
                path = cases / f"{vname}.toml"
                text = write_case(path, raw, f"{name}: ballistic limit run {values}")
                items.append((var, path, text))
            rows = run_variants(items, ex, say)
            outs = []
            for (c, x), row in zip(points, rows):
                o = crit.perforated(row)
                all_rows.append({at: at_values[c], vary: x, "perforated": o} | row)
                outs.append(o)
            return outs
        return evaluate

    n = len(at_values)
    width = workers if workers else (default_workers() if scheduler is None else n)
    say(f"{name}: ballistic limit in {vary} over [{lo}, {hi}] to {tol} for {at} = "
        f"{', '.join(map(str, at_values))}; perforated: {crit.describe()}; "
        f"on {where(scheduler, workers)}")
    with executor(scheduler, workers) as ex:
        state = search(evaluate_on(ex), n, x_lo, x_hi, x_tol, width if workers != 0 else 1)
    at_col = at
    curve = pd.DataFrame({at_col: at_values,
                          f"{vary} limit" + (f" [{unit}]" if unit else ""): [s["limit"] for s in state],
                          "below" + (f" [{unit}]" if unit else ""): [s["lo"] for s in state],
                          "above" + (f" [{unit}]" if unit else ""): [s["hi"] for s in state],
                          "status": [s["status"] for s in state],
                          "runs": [s["runs"] for s in state]})
    curve["criterion"] = crit.describe()
    from impactsim.output.atomic import replacing

    with replacing(folder / "ballistic.csv") as tmp:
        curve.to_csv(tmp, index=False)
    runs = pd.DataFrame.from_records([{k: v for k, v in r.items() if k != "case_sha"}
                                      for r in all_rows])
    with replacing(folder / "runs.csv") as tmp:
        runs.to_csv(tmp, index=False)
    png = plot_curve(curve, at, vary, unit, folder / "ballistic.png", crit, reference)
    say(f"curve: {folder / 'ballistic.csv'}, {png}; runs: {folder / 'runs.csv'}")
    return curve, folder


def _number(v) -> float:
    return v if isinstance(v, (int, float)) else split_quantity(v, "value")[0]


def plot_curve(curve, at: str, vary: str, unit: str, path: Path, crit: Criterion,
               reference: Path | None = None) -> Path:
    """The limit against the second key, the bracketing interval as error bars, and a user's
    reference curve (a CSV file whose first two columns are the two keys' values) if given."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np
    import pandas as pd

    from impactsim.output.atomic import replacing

    xs = np.array([_number(v) for v in curve[at]])
    lim = curve.iloc[:, 1].to_numpy(float)
    lo, hi = curve.iloc[:, 2].to_numpy(float), curve.iloc[:, 3].to_numpy(float)
    at_unit = next((split_quantity(v, "")[1] for v in curve[at] if isinstance(v, str)), "")
    fig, ax = plt.subplots(figsize=(6.4, 4.4), dpi=120)
    ok = np.isfinite(lim)
    ax.errorbar(xs[ok], lim[ok], yerr=[lim[ok] - lo[ok], hi[ok] - lim[ok]], fmt="o-",
                capsize=3, label="impactsim (bracket)")
    if reference is not None:
        ref = pd.read_csv(reference)
        ax.plot(ref.iloc[:, 0], ref.iloc[:, 1], "k--", label=f"reference ({Path(reference).name})")
    ax.set_xlabel(at + (f" [{at_unit}]" if at_unit else ""))
    ax.set_ylabel(vary + (f" [{unit}]" if unit else ""))
    ax.set_title(f"Ballistic limit: {crit.describe()}", fontsize=10)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    with replacing(path) as tmp:
        fig.savefig(tmp)
    plt.close(fig)
    return path
