"""`make bench-peers`: impactsim beside a peer code, each refined until its answer has converged.

A code is fast if it reaches a trustworthy answer soon, not if one step is cheap. So each code
runs its own packaged Taylor bar over a sequence of refinements, from coarse to fine, until the
bar's final length changes by less than TOLERANCE between two levels; the wall time of the
first level that meets this (the converged run) is the code's time to the answer. Both run on
one thread, one after the other, in this one invocation:

- impactsim: `cases/taylor-bar.toml` (OFHC copper, 3-D, Johnson-Cook + Mie-Grueneisen, 190 m/s,
  80 us) at mesh sizes 1.6 mm * 2^(-k/3), once with the case's default element and once with
  hexahedra (the stiffness hourglass form, as in `make accuracy`);
- PySPH (installed by `make bench-peers` into its own virtual environment): its packaged
  `solid_mech/taylor_bar.py` (2-D plane-strain steel bar, 200 m/s, 25 us, fixed 1 ns step) at
  particle spacings 0.384848 mm * 2^(k/2), run by benchmarks/peers/pysph_taylor.py.

The problems differ (the peer's is 2-D and shorter), which is why the figure compared is the
time each code needs to converge its own problem, not a time per step. OpenRadioss' recorded
per-element figure (docs/performance.md, not measured in this run) is printed as a fixed
reference row.

Writes the table between the `peers` markers of docs/performance.md (with --write) and prints it.
"""

from __future__ import annotations

import argparse
import contextlib
import io
import json
import os
import platform
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
TOLERANCE = 0.01
COPPER_SIZES = [1.6e-3 * 2.0 ** (-k / 3) for k in range(0, 7)]  # 1.6 ... 0.4 mm
PYSPH_DX0 = 0.000384848  # the example's own spacing [m]
PYSPH_SPACINGS = [PYSPH_DX0 * 2.0 ** (k / 2) for k in (4, 3, 2, 1, 0, -1)]  # 1.54 ... 0.27 mm
SERIES = {"impactsim (default element)": [],
          "impactsim (hex8)": ['body.0.element="hex8"', 'body.0.hourglass="stiffness"']}
# OpenRadioss' one-thread tet4 cycle as recorded in docs/performance.md (DESIGN.md): not a run
OPENRADIOSS_NS_PER_TET_STEP = 620.0
BEGIN, END = "<!-- peers:begin -->", "<!-- peers:end -->"


def impactsim_level(size: float, overrides: list[str]) -> dict:
    """One run of the copper Taylor bar at mesh size `size` [m]."""
    from benchmarks.accuracy_measure import taylor_bar
    from impactsim.case import load_case
    from impactsim.solver.run import run_case

    case = load_case(ROOT / "cases" / "taylor-bar.toml",
                     overrides=[f'body.0.mesh_size="{size * 1e3:.6g} mm"', "run.threads=1",
                                "output.frames=1", *overrides])
    with tempfile.TemporaryDirectory() as out:
        cpu = time.process_time()
        with contextlib.redirect_stderr(io.StringIO()):
            summary = run_case(case, Path(out), progress=False)
        meshing = summary["seconds_per_pass"].get("meshing", 0.0)
        cpu = time.process_time() - cpu - meshing
        length = taylor_bar(case, Path(out), summary)["length"].value
    return {"h_mm": size * 1e3, "elements": summary["elements"], "steps": summary["steps"],
            "wall_seconds": summary["wall_seconds"] - meshing, "cpu_seconds": cpu,
            "length_mm": length * 1e3}


def pysph_level(python: str, dx: float) -> dict:
    """One run of PySPH's Taylor bar at spacing `dx` [m], in the peers' environment."""
    env = {**os.environ, "OMP_NUM_THREADS": "1"}
    proc = subprocess.run([python, str(Path(__file__).parent / "peers" / "pysph_taylor.py"),
                           "--dx", repr(dx)], capture_output=True, text=True, env=env, check=False)
    if proc.returncode != 0:
        raise RuntimeError(f"PySPH run at dx={dx} failed:\n{proc.stderr[-2000:]}")
    row = json.loads(proc.stdout.strip().splitlines()[-1])
    return {"h_mm": dx * 1e3, "elements": row["particles"], "steps": row["steps"],
            "wall_seconds": row["wall_seconds"], "cpu_seconds": row["cpu_seconds"],
            "length_mm": row["length"] * 1e3}


def refine(name: str, levels: list, run_level) -> dict:
    """Run `levels` coarse to fine until the length changes by less than TOLERANCE."""
    rows = []
    for x in levels:
        row = run_level(x)
        if rows:
            row["change"] = abs(row["length_mm"] - rows[-1]["length_mm"]) / row["length_mm"]
        rows.append(row)
        print(f"  {name}: h {row['h_mm']:.3f} mm, {row['elements']} elements, {row['steps']} "
              f"steps, length {row['length_mm']:.3f} mm, change {row.get('change', float('nan')):.2%},"
              f" {row['wall_seconds']:.1f} s wall, {row['cpu_seconds']:.1f} s CPU", flush=True)
        if row.get("change", 1.0) < TOLERANCE:
            return {"name": name, "rows": rows, "converged": row}
    return {"name": name, "rows": rows, "converged": None}


def _warm_pysph(python: str) -> None:
    """Build PySPH's equations for this problem once (cached in ~/.pysph), outside the timing."""
    subprocess.run([python, str(Path(__file__).parent / "peers" / "pysph_taylor.py"),
                    "--dx", "0.0016", "--tf", "2e-8"], capture_output=True, check=True)


def table(results: list[dict], machine: str) -> str:
    lines = [f"Measured by `make bench-peers` on {machine}, one thread each, in one run. "
             f"Converged: the first level whose final length is within {TOLERANCE:.0%} of the "
             "level before.", "",
             "| code | problem | levels run | converged at h | elements / particles | steps "
             "| final length | wall s (CPU s) of the converged run | sum of the levels' wall s |",
             "| --- | --- | --- | --- | --- | --- | --- | --- | --- |"]
    for r in results:
        c = r["converged"]
        total = sum(row["wall_seconds"] for row in r["rows"])
        problem = r["problem"]
        if c is None:
            last = r["rows"][-1]
            lines.append(f"| {r['name']} | {problem} | {len(r['rows'])} | not converged "
                         f"(last change {last.get('change', float('nan')):.1%}) | "
                         f"{last['elements']:,} | {last['steps']:,} | {last['length_mm']:.2f} mm "
                         f"| — | {total:.1f} |")
        else:
            lines.append(f"| {r['name']} | {problem} | {len(r['rows'])} | {c['h_mm']:.3f} mm | "
                         f"{c['elements']:,} | {c['steps']:,} | {c['length_mm']:.2f} mm | "
                         f"{c['wall_seconds']:.1f} ({c['cpu_seconds']:.1f}) | {total:.1f} |")
    lines.append(f"| OpenRadioss (recorded, **not measured in this run**) | tet4 element update | "
                 f"— | — | — | — | — | {OPENRADIOSS_NS_PER_TET_STEP:.0f} ns per tet-step, one "
                 "thread (docs/performance.md) | — |")
    done = {r["name"]: r["converged"] for r in results if r["converged"]}
    ours = [c for n, c in done.items() if n.startswith("impactsim")]
    if "PySPH" in done and ours:
        best = min(ours, key=lambda c: c["cpu_seconds"])
        p = done["PySPH"]
        lines += ["", f"Time to a converged answer, PySPH over impactsim's fastest series: "
                      f"{p['cpu_seconds'] / best['cpu_seconds']:.1f}× in CPU time, "
                      f"{p['wall_seconds'] / best['wall_seconds']:.1f}× in wall time (trust the "
                      "CPU ratio: on a shared machine the wall time measures the other load "
                      "too)."]
    lines += ["", "Every level run:", "",
              "| code | h [mm] | elements / particles | steps | final length [mm] | change "
              "| wall s | CPU s |", "| --- | --- | --- | --- | --- | --- | --- | --- |"]
    for r in results:
        for row in r["rows"]:
            change = f"{row['change']:.2%}" if "change" in row else "—"
            lines.append(f"| {r['name']} | {row['h_mm']:.3f} | {row['elements']:,} | "
                         f"{row['steps']:,} | {row['length_mm']:.3f} | {change} | "
                         f"{row['wall_seconds']:.1f} | {row['cpu_seconds']:.1f} |")
    return "\n".join(lines)


def write_table(text: str) -> None:
    path = ROOT / "docs" / "performance.md"
    doc = path.read_text()
    head, _, rest = doc.partition(BEGIN)
    _, _, tail = rest.partition(END)
    path.write_text(f"{head}{BEGIN}\n{text}\n{END}{tail}")


def machine() -> str:
    model = "unknown CPU"
    with contextlib.suppress(OSError):
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                model = line.split(":", 1)[1].strip()
                break
    import llvmlite.binding as llvm

    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
    return (f"{model} (LLVM host {llvm.get_host_cpu_name()}, {platform.machine()}), "
            f"load average {load:.1f} at the start")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--peer-python", required=True, help="python of the environment with PySPH")
    parser.add_argument("--write", action="store_true", help="write the table into docs/performance.md")
    parser.add_argument("--only", choices=["impactsim", "pysph"], help="run one code only")
    args = parser.parse_args(argv)
    sys.path.insert(0, str(ROOT))
    os.environ.setdefault("NUMBA_NUM_THREADS", "1")

    about = machine()
    print(f"peers on {about}", flush=True)
    results = []
    if args.only != "pysph":
        for name, overrides in SERIES.items():
            r = refine(name, COPPER_SIZES, lambda h, o=overrides: impactsim_level(h, o))
            results.append({**r, "problem": "3-D copper bar, 190 m/s, 80 us"})
    if args.only != "impactsim":
        _warm_pysph(args.peer_python)
        r = refine("PySPH", PYSPH_SPACINGS, lambda dx: pysph_level(args.peer_python, dx))
        results.append({**r, "problem": "2-D steel bar, 200 m/s, 25 us"})
    text = table(results, about)
    print("\n" + text)
    if args.write:
        write_table(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
