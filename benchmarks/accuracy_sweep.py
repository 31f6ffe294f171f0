"""`make sweep SWEEP=cases/sweeps/<file>.toml`: run the variants of one case.

A sweep file names a base case and sets of `--set` overrides (docs/user-guide.md, "Sweeps"):

    base = "../taylor-bar.toml"          # relative to the sweep file
    set = ["output.frames=4"]            # optional: applied to every variant
    [vary]                               # optional: every combination of these values
    "body.0.mesh_size" = ["1.6 mm", "0.8 mm"]
    "run.element" = ["tet4", "anp"]
    [[variant]]                          # optional: named override sets, run as well
    name = "fine-cfl"
    set = ["run.cfl=0.3"]

Each variant is the base case's tables with the overrides applied, checked by loading it, and
written with tomli-w to out/sweeps/<sweep name>/<variant>.toml (relative mesh-file paths made
absolute); then the variants run, --jobs at a time, each into out/sweeps/<sweep>/<variant>/,
and out/sweeps/<sweep>/sweep.csv lists them (elements, steps, wall seconds, how they ended).
"""

from __future__ import annotations

import argparse
import csv
import itertools
import re
import sys
import tomllib
from concurrent.futures import ProcessPoolExecutor
from multiprocessing import get_context
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))

SWEEP_KEYS = {"base", "name", "set", "vary", "variant"}


class SweepError(Exception):
    pass


def toml_value(value: object) -> str:
    """A value as TOML text (the right-hand side of a --set override)."""
    import tomli_w

    return tomli_w.dumps({"v": value}).split("=", 1)[1].strip()


def _slug(text: str) -> str:
    return re.sub(r"[^A-Za-z0-9.+-]+", "", text.replace(" ", "")) or "v"


def variants(sweep: dict, where: str) -> dict[str, list[str]]:
    """Variant name -> overrides (the sweep's common `set` first)."""
    unknown = set(sweep) - SWEEP_KEYS
    if unknown:
        raise SweepError(f"{where}: unknown keys {sorted(unknown)}; a sweep has "
                         f"{sorted(SWEEP_KEYS)}")
    common = list(sweep.get("set", []))
    out: dict[str, list[str]] = {}
    vary = sweep.get("vary", {})
    if vary:
        keys = list(vary)
        for key in keys:
            if not isinstance(vary[key], list) or not vary[key]:
                raise SweepError(f"{where}: vary.{key} must be a non-empty list of values")
        for combo in itertools.product(*(vary[k] for k in keys)):
            name = "_".join(f"{k.split('.')[-1]}-{_slug(str(v))}" for k, v in zip(keys, combo))
            out[name] = common + [f"{k}={toml_value(v)}" for k, v in zip(keys, combo)]
    for i, var in enumerate(sweep.get("variant", [])):
        if "name" not in var:
            raise SweepError(f"{where}: variant[{i}] needs a name")
        out[_slug(var["name"])] = common + list(var.get("set", []))
    if not out:
        raise SweepError(f"{where}: nothing to run: give [vary] values or [[variant]] tables")
    return out


def write_variants(sweep_path: Path, out_root: Path) -> tuple[str, list[Path]]:
    """Write every variant's case file; return the sweep name and the files."""
    import tomli_w

    from impactsim.case import load_case
    from impactsim.case.overrides import apply_overrides

    sweep = tomllib.loads(sweep_path.read_text())
    if "base" not in sweep:
        raise SweepError(f"{sweep_path}: 'base' (the case file to vary) is missing")
    base = (sweep_path.parent / sweep["base"]).resolve()
    name = sweep.get("name", sweep_path.stem)
    folder = out_root / name
    folder.mkdir(parents=True, exist_ok=True)
    files = []
    for vname, overrides in variants(sweep, str(sweep_path)).items():
        raw = tomllib.loads(base.read_text())
        apply_overrides(raw, overrides)
        raw.setdefault("run", {})["name"] = vname
        for body in raw.get("body", []):  # mesh files stay where the base case found them
            if isinstance(body.get("path"), str) and not Path(body["path"]).is_absolute():
                body["path"] = str((base.parent / body["path"]).resolve())
        path = folder / f"{vname}.toml"
        path.write_text(f"# {name}: {base.name} with {overrides}\n" + tomli_w.dumps(raw))
        load_case(path)  # a bad override stops the sweep before anything runs
        files.append(path)
    return name, files


def run_variant(path: str) -> dict:
    from impactsim.case import load_case
    from impactsim.solver.run import run_case

    p = Path(path)
    s = run_case(load_case(p), p.with_suffix(""), progress=False)
    return {"variant": p.stem, "elements": s["elements"], "steps": s["steps"],
            "wall_seconds": round(s["wall_seconds"], 3),
            "energy_balance_error": s["energy_balance_error"], "stopped": s["stopped"] or ""}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description="Run the variants of a sweep file.")
    ap.add_argument("sweep", type=Path)
    ap.add_argument("--jobs", type=int, default=1, help="variants run at a time")
    ap.add_argument("--out", type=Path, default=Path("out") / "sweeps")
    ap.add_argument("--write-only", action="store_true", help="write the variants, do not run")
    args = ap.parse_args(argv)
    from impactsim.case import CaseError

    try:
        name, files = write_variants(args.sweep, args.out)
    except (SweepError, CaseError, OSError, tomllib.TOMLDecodeError) as err:
        print(f"sweep: {err}", file=sys.stderr)
        return 2
    print(f"{name}: {len(files)} variants in {args.out / name}", flush=True)
    if args.write_only:
        return 0
    rows = []
    with ProcessPoolExecutor(max(1, args.jobs), mp_context=get_context("spawn")) as pool:
        for row in pool.map(run_variant, [str(f) for f in files]):
            print(f"  {row['variant']:<40} {row['elements']:>8} el {row['steps']:>7} steps "
                  f"{row['wall_seconds']:9.2f} s {row['stopped']}", flush=True)
            rows.append(row)
    with open(args.out / name / "sweep.csv", "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    return 0


if __name__ == "__main__":
    sys.exit(main())
