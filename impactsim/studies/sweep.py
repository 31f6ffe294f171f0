"""Sweeps: the variants of one case, run on Dask, gathered into one results table.

A sweep file (TOML, docs/studies.md) names a base case and what to vary:

    base = "../sphere-plate.toml"        # relative to the sweep file
    name = "sphere-plate-grid"           # optional (default: the file's stem)
    set = ["output.frames=2"]            # optional: --set overrides of every variant
    [vary]                               # every combination of these values (product)
    "body.sphere.radius" = ["4 mm", "6 mm"]
    "body.sphere.speed" = { start = 2000, stop = 4000, num = 3, unit = "m/s" }   # a range
    [zip]                                # lists of one length, taken together (one value each)
    "body.plate.size" = [["40 mm", "40 mm", "1 mm"], ["40 mm", "40 mm", "2 mm"]]
    "body.plate.position" = [[0, 0, "-0.5 mm"], [0, 0, "-1 mm"]]
    [[variant]]                          # named override sets, run as well
    name = "fine"
    set = ["body.plate.mesh_size=0.25 mm"]

[vary] and [zip] combine as a product (each vary combination with each zip row). A range is a
table {start, stop, num} (end points included) or {start, stop, step}, with an optional unit.
`body.<name or index>.speed` is a key of studies only: the body's speed along the direction of
its velocity in the base case (vector keys cannot be bisected or plotted on an axis).

Each variant is the base case with its overrides, checked by loading it, written with tomli-w
to <out>/<variant>.toml (a plain case file), and run into <out>/<variant>/. When a variant ends,
its row is written to <out>/<variant>/row.json; a re-run skips the variants whose row says they
finished (status ok or stopped) for the same case file text, and runs the others again. A
variant that fails (an exception) is recorded with its error and does not stop the others. The
table <out>/results.csv and results.parquet has one row per variant (`results_row`).
"""

from __future__ import annotations

import hashlib
import itertools
import json
import math
import re
import time
import tomllib
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

SWEEP_KEYS = {"base", "name", "set", "vary", "zip", "variant"}
FINISHED = ("ok", "stopped")


class SweepError(Exception):
    """A sweep file that cannot be read: printed as one line, exit 2."""


@dataclass
class Variant:
    name: str
    overrides: list[str]  # --set overrides, common ones first
    values: dict = field(default_factory=dict)  # the varied keys' values (the table's columns)
    special: dict = field(default_factory=dict)  # study-only keys (body.X.speed)


@dataclass
class Sweep:
    name: str
    base: Path
    variants: list[Variant]
    keys: list[str]  # the varied keys, in order


def toml_value(value: object) -> str:
    """A value as TOML text (the right-hand side of a --set override)."""
    import tomli_w

    return tomli_w.dumps({"v": value}).split("=", 1)[1].strip()


def slug(text: str) -> str:
    return re.sub(r"[^A-Za-z0-9.+-]+", "", str(text).replace(" ", "")) or "v"


def expand_range(value: object, where: str) -> list:
    """A list of values as given, or the values of a range table."""
    if isinstance(value, list):
        if not value:
            raise SweepError(f"{where}: an empty list of values")
        return value
    if isinstance(value, dict):
        import numpy as np

        unknown = set(value) - {"start", "stop", "num", "step", "unit"}
        if unknown or "start" not in value or "stop" not in value or \
                ("num" in value) == ("step" in value):
            raise SweepError(f"{where}: a range is {{start, stop, num}} or {{start, stop, step}} "
                             "with an optional unit")
        a, b = float(value["start"]), float(value["stop"])
        if "num" in value:
            n = int(value["num"])
            if n < 1:
                raise SweepError(f"{where}: num must be >= 1")
            vals = [a] if n == 1 else [a + (b - a) * i / (n - 1) for i in range(n)]
        else:
            step = float(value["step"])
            if step == 0 or (b - a) / step < 0:
                raise SweepError(f"{where}: step {step} does not go from {a} to {b}")
            n = int(math.floor((b - a) / step * (1 + 1e-12))) + 1
            vals = list(a + step * np.arange(n))
        vals = [float(f"{v:.12g}") for v in vals]
        unit = value.get("unit")
        return [f"{v:.12g} {unit}" for v in vals] if unit else vals
    raise SweepError(f"{where}: expected a list of values or a range table, got {value!r}")


def is_special(key: str) -> bool:
    return key.split(".")[-1] == "speed" and key.startswith("body")


def make_variant(name: str, common: list[str], values: dict) -> Variant:
    ov = list(common)
    special = {}
    for k, v in values.items():
        if is_special(k):
            special[k] = v
        else:
            ov.append(f"{k}={toml_value(v)}")
    return Variant(name, ov, dict(values), special)


def variant_name(values: dict) -> str:
    return "_".join(f"{k.split('.')[-1]}-{slug(_show(v))}" for k, v in values.items())


def _show(v) -> str:
    return ",".join(_show(x) for x in v) if isinstance(v, list) else str(v)


def read_sweep(path: Path) -> Sweep:
    """The sweep file at `path`, its variants expanded (module docstring)."""
    path = Path(path)
    try:
        raw = tomllib.loads(path.read_text())
    except FileNotFoundError:
        raise SweepError(f"{path}: file not found") from None
    except tomllib.TOMLDecodeError as err:
        raise SweepError(f"{path}: invalid TOML: {err}") from None
    unknown = set(raw) - SWEEP_KEYS
    if unknown:
        raise SweepError(f"{path}: unknown keys {sorted(unknown)}; a sweep has "
                         f"{sorted(SWEEP_KEYS)}")
    if "base" not in raw:
        raise SweepError(f"{path}: base: the case file to vary is missing")
    base = (path.parent / raw["base"]).resolve()
    if not base.is_file():
        raise SweepError(f"{path}: base: {base} not found")
    common = [str(s) for s in raw.get("set", [])]
    vary = {k: expand_range(v, f"{path}: vary.{k}") for k, v in raw.get("vary", {}).items()}
    zipped = {k: expand_range(v, f"{path}: zip.{k}") for k, v in raw.get("zip", {}).items()}
    if len({len(v) for v in zipped.values()}) > 1:
        raise SweepError(f"{path}: zip: the lists have different lengths "
                         f"({', '.join(f'{k}: {len(v)}' for k, v in zipped.items())})")
    keys = list(vary) + list(zipped)
    variants = []
    if keys:
        zrows = [dict(zip(zipped, row)) for row in zip(*zipped.values())] if zipped else [{}]
        for combo in itertools.product(*vary.values()):
            for zrow in zrows:
                values = dict(zip(vary, combo)) | zrow
                variants.append(make_variant(variant_name(values), common, values))
    for i, var in enumerate(raw.get("variant", [])):
        if "name" not in var:
            raise SweepError(f"{path}: variant[{i}].name is missing")
        variants.append(Variant(slug(var["name"]), common + [str(s) for s in var.get("set", [])]))
    if not variants:
        raise SweepError(f"{path}: nothing to run: give [vary], [zip] or [[variant]] tables")
    names = [v.name for v in variants]
    dup = sorted({n for n in names if names.count(n) > 1})
    if dup:
        raise SweepError(f"{path}: two variants are named {dup[0]!r}")
    return Sweep(raw.get("name", path.stem), base, variants, keys)


def apply_special(raw: dict, key: str, value, where: str) -> None:
    """Set a study-only key in the raw case tables: body.<name or index>.speed."""
    from impactsim.case import CaseError
    from impactsim.case.units import parse_quantity

    parts = key.split(".")
    if len(parts) != 3:
        raise SweepError(f"{where}: {key}: expected body.<name or index>.speed")
    bodies = raw.get("body", [])
    sel = parts[1]
    body = None
    if sel.isdigit() and int(sel) < len(bodies):
        body = bodies[int(sel)]
    else:
        body = next((b for b in bodies if b.get("name") == sel), None)
    if body is None:
        raise SweepError(f"{where}: {key}: no body {sel!r} in the base case")
    try:
        speed = parse_quantity(value, "velocity", key)
        vel = [parse_quantity(c, "velocity", f"body.{sel}.velocity")
               for c in body.get("velocity", [0, 0, 0])]
    except CaseError as err:
        raise SweepError(f"{where}: {err}") from None
    norm = math.sqrt(sum(c * c for c in vel))
    if norm == 0.0:
        raise SweepError(f"{where}: {key}: body {sel!r} has no velocity in the base case, so "
                         "its speed has no direction; vary body.X.velocity instead")
    body["velocity"] = [c / norm * speed for c in vel]


def variant_case(base: Path, variant: Variant, where: str = "") -> dict:
    """The raw tables of a variant: the base case with its overrides (not yet validated)."""
    from impactsim.case.overrides import apply_overrides

    try:
        raw = tomllib.loads(base.read_text())
    except tomllib.TOMLDecodeError as err:
        raise SweepError(f"{base}: invalid TOML: {err}") from None
    apply_overrides(raw, variant.overrides)
    for k, v in variant.special.items():
        apply_special(raw, k, v, where or str(base))
    raw.setdefault("run", {})["name"] = variant.name
    for body in raw.get("body", []):  # mesh files stay where the base case found them
        if isinstance(body.get("path"), str) and not Path(body["path"]).is_absolute():
            body["path"] = str((base.parent / body["path"]).resolve())
    out = raw.get("output", {})
    if isinstance(out.get("directory"), str):  # every variant runs into its own folder
        del out["directory"]
    return raw


def write_case(path: Path, raw: dict, comment: str) -> str:
    """Write a case file (atomically) and check it by loading it; returns its text."""
    import tomli_w

    from impactsim.case import load_case
    from impactsim.output.atomic import write_text

    text = f"# {comment}\n" + tomli_w.dumps(raw)
    write_text(path, text)
    load_case(path)  # a bad override stops the study before anything runs
    return text


def case_digest(text: str) -> str:
    return hashlib.sha256(text.encode()).hexdigest()[:16]


def results_row(summary: dict) -> dict:
    """The summary's quantities as flat columns (units in the names): the run, the energy
    balance, fracture totals, and per body its residual speed and velocity, fragments, and for a
    plate whether it is perforated (a hole through its thickness: `hole.area > 0`, the hole
    measure of fracture/measures.py) and the hole's equivalent diameter and extent."""
    row = {"elements": summary.get("elements"), "steps": summary.get("steps"),
           "time [s]": summary.get("time"), "run wall [s]": summary.get("wall_seconds"),
           "energy_balance_error": summary.get("energy_balance_error"),
           "stopped": summary.get("stopped") or ""}
    for key in ("particles", "eroded_elements", "mass_error"):
        if key in summary:
            row[key] = summary[key]
    for name, b in summary.get("bodies", {}).items():
        if "residual_speed" in b:
            row[f"{name}.residual_speed [m/s]"] = b["residual_speed"]
            for c, val in zip("xyz", b["residual_velocity"]):
                row[f"{name}.residual_velocity_{c} [m/s]"] = val
        else:
            for c, val in zip("xyz", b.get("mean_velocity", [])):
                row[f"{name}.mean_velocity_{c} [m/s]"] = val
        if "fragments" in b:
            row[f"{name}.fragments"] = b["fragments"]
        if "hole" in b:
            hole = b["hole"]
            row[f"{name}.perforated"] = bool(hole["area"] > 0.0)
            row[f"{name}.hole_diameter [m]"] = hole["diameter_equivalent"]
            row[f"{name}.hole_extent_1 [m]"] = hole["extent"][0]
            row[f"{name}.hole_extent_2 [m]"] = hole["extent"][1]
        for key, val in b.items():  # derived results of a scene (rod on a wall...)
            if key in ("final_length", "foot_diameter"):
                row[f"{name}.{key} [m]"] = val
    return row


def run_variant(case_file: str, out_dir: str) -> dict:
    """Run one variant (in a worker); returns its row, also written to out_dir/row.json.
    Never raises for a failed run: the row has status 'failed' and the error."""
    from impactsim.case import load_case
    from impactsim.output.atomic import write_text
    from impactsim.solver.run import run_case

    t0 = time.perf_counter()
    text = Path(case_file).read_text()
    row = {"status": "failed", "error": "", "case_sha": case_digest(text)}
    try:
        summary = run_case(load_case(case_file), Path(out_dir), progress=False)
        row.update(results_row(summary))
        row["status"] = "stopped" if summary.get("stopped") else "ok"
    except Exception as err:  # recorded, and the other variants go on
        row["error"] = f"{type(err).__name__}: {err}".splitlines()[0][:500]
    row["wall [s]"] = time.perf_counter() - t0
    Path(out_dir).mkdir(parents=True, exist_ok=True)
    write_text(Path(out_dir) / "row.json", json.dumps(row, indent=1, default=str) + "\n")
    return row


def finished_row(out_dir: Path, text: str) -> dict | None:
    """The row of a variant that finished earlier with the same case text, else None."""
    try:
        row = json.loads((out_dir / "row.json").read_text())
    except (OSError, ValueError):
        return None
    if row.get("status") in FINISHED and row.get("case_sha") == case_digest(text):
        return row
    return None


def prepare(sweep: Sweep, folder: Path) -> list[tuple[Variant, Path, str]]:
    folder.mkdir(parents=True, exist_ok=True)
    out = []
    for var in sweep.variants:
        raw = variant_case(sweep.base, var, str(sweep.base))
        path = folder / f"{var.name}.toml"
        text = write_case(path, raw, f"{sweep.name}: {sweep.base.name} with "
                                     f"{var.overrides + [f'{k}={v}' for k, v in var.special.items()]}")
        out.append((var, path, text))
    return out


def run_variants(items: list[tuple[Variant, Path, str]], ex,
                 say: Callable[[str], None] = print) -> list[dict]:
    """Run on `ex` (cluster.executor) the variants not finished yet (module docstring); rows in
    the order of `items`, each with `skipped` saying whether it ran now."""
    rows: list[dict | None] = [None] * len(items)
    todo = []
    for i, (var, path, text) in enumerate(items):
        old = finished_row(path.with_suffix(""), text)
        if old is not None:
            rows[i] = old | {"skipped": True}
        else:
            todo.append(i)
    if len(todo) < len(items):
        say(f"{len(items) - len(todo)} variant(s) finished earlier, skipped")
    args = [(str(items[i][1]), str(items[i][1].with_suffix(""))) for i in todo]
    for j, res in ex.map(run_variant, args):
        i = todo[j]
        if isinstance(res, Exception):  # the worker itself was lost
            res = {"status": "failed", "error": f"{type(res).__name__}: {res}"[:500]}
        rows[i] = res | {"skipped": False}
        say(f"  {items[i][0].name:<44} {res['status']:<8} "
            f"{res.get('wall [s]', float('nan')):8.1f} s {res.get('error', '')}")
    return rows


def where(scheduler: str | None, workers: int | None) -> str:
    if scheduler:
        return f"scheduler {scheduler}"
    return "this process" if workers == 0 else f"{workers or 'one per core'} local worker(s)"


def table(sweep: Sweep, items, rows: list[dict]):
    """The results as a pandas DataFrame: variant, varied keys, status, then the quantities."""
    import pandas as pd

    records = []
    for (var, _, _), row in zip(items, rows):
        rec = {"variant": var.name}
        for k in sweep.keys:
            v = var.values.get(k)
            rec[k] = _show(v) if isinstance(v, list) else v
        rec.update({k: v for k, v in row.items() if k != "case_sha"})
        records.append(rec)
    df = pd.DataFrame.from_records(records)
    first = ["variant", *sweep.keys, "status", "error", "wall [s]", "skipped"]
    cols = [c for c in first if c in df.columns] + [c for c in df.columns if c not in first]
    return df[cols]


def write_table(df, folder: Path) -> tuple[Path, Path]:
    """results.csv and results.parquet in `folder`, each replaced atomically."""
    from impactsim.output.atomic import replacing

    csv, pq = folder / "results.csv", folder / "results.parquet"
    with replacing(csv) as tmp:
        df.to_csv(tmp, index=False)
    pdf = df.copy()
    for c in pdf.columns:  # mixed-type columns (a key varied over numbers and strings)
        if pdf[c].dtype == object:
            kinds = {type(v) for v in pdf[c] if v is not None and v == v}
            if len(kinds) > 1:
                pdf[c] = pdf[c].map(lambda v: None if v is None else str(v))
    with replacing(pq) as tmp:
        pdf.to_parquet(tmp, index=False)
    return csv, pq


def run_sweep(sweep_file: Path, out: Path | None = None, scheduler: str | None = None,
              workers: int | None = None, say: Callable[[str], None] = print):
    """Run the sweep file; returns (the results DataFrame, the output folder)."""
    sweep = read_sweep(Path(sweep_file))
    folder = Path(out) if out is not None else Path("out") / "sweeps" / sweep.name
    from impactsim.studies.cluster import executor

    items = prepare(sweep, folder)
    say(f"{sweep.name}: {len(items)} variant(s) in {folder}, on {where(scheduler, workers)}")
    with executor(scheduler, workers) as ex:
        rows = run_variants(items, ex, say)
    df = table(sweep, items, rows)
    csv, pq = write_table(df, folder)
    say(f"results: {csv} and {pq}")
    return df, folder
