"""The three fracture methods on one scene (issue 12, item 6): the three-plate shield of
cases/three-plate-shield.toml with

- node separation + distortion erosion [Z] (the case as it is),
- strain erosion alone [R20]: a cell whose plastic strain reaches the fracture strain of [Z]
  (0.8 sphere, 1.0 plates) is deleted anywhere, no separation, no distortion erosion,
- spall/loosening + particles [D19]: the library's spall strengths and loosening, fractured
  surface cells become particles, no separation, no distortion erosion;

all on the coarse meshes of tests/hard/test_three_plate_shield.py, to 25 us, one thread. Writes
the table (deleted elements, energy that left with them, d1, d2, fragments, wall time) and a
picture of each debris cloud at the end into docs/fracture.md (between the markers) and
docs/fracture/. `make fracture-compare`; COMPARE_END="10 us" for a shorter run;
COMPARE_REUSE=1 rewrites the table and pictures from the runs already in out/compare-fracture.
"""

from __future__ import annotations

import os
import re
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
CASE = ROOT / "cases" / "three-plate-shield.toml"
DOC = ROOT / "docs" / "fracture.md"
PICS = ROOT / "docs" / "fracture"
OUT = ROOT / "out" / "compare-fracture"
BEGIN, END = "<!-- compare_fracture: begin -->", "<!-- compare_fracture: end -->"
COARSE = ["body.plate-1.mesh_size=2 mm", "body.plate-2.mesh_size=2 mm",
          "body.plate-3.mesh_size=2.65 mm", "body.sphere.mesh_size=2 mm", "output.frames=1",
          "output.history_every=20", "run.threads=1"]
SEP = 'failure = { fracture_strain = %s, spall_strength = "none", loosening = "none" }'


def variants(text: str) -> dict[str, str]:
    """Case texts of the three methods (module docstring)."""
    no_dist = text.replace('distortion_interval = "50 ns"\n', "")
    erosion = no_dist
    spall = no_dist
    for fs in ("0.8", "1.0"):
        erosion = erosion.replace(SEP % fs, "failure = { erosion = \"plastic-strain\", "
                                  f"erosion_value = {fs}, spall_strength = \"none\", "
                                  "loosening = \"none\" }")
        spall = spall.replace(SEP % fs, "failure = {}")
    erosion = erosion.replace("[fracture]\n", "[fracture]\nerosion_region = \"anywhere\"\n")
    spall = spall.replace("[fracture]\n", "[fracture]\nparticles_per_element = 1\n")
    out = {"node separation + distortion erosion": text, "strain erosion": erosion,
           "spall/loosening + particles": spall}
    assert erosion != text and spall != text and "fracture_strain" not in erosion + spall
    return out


def run_variant(name: str, text: str, end: str) -> dict:
    from impactsim.case import load_case_text
    from impactsim.solver.run import run_case

    case = load_case_text(text, overrides=COARSE + [f"run.end_time={end}"])
    out = OUT / re.sub(r"[^a-z]+", "-", name.lower()).strip("-")
    t0 = time.perf_counter()
    s = run_case(case, out, progress=False, overwrite=True)
    s["_wall"] = time.perf_counter() - t0
    s["_dir"] = out
    return s


def reuse(name: str) -> dict:
    """The summary of an earlier run of the variant (COMPARE_REUSE=1: the table again without
    the runs)."""
    import json

    out = OUT / re.sub(r"[^a-z]+", "-", name.lower()).strip("-")
    s = json.loads((out / "summary.json").read_text())
    s["_wall"], s["_dir"] = s["wall_seconds"], out
    return s


def picture(run_dir: Path, target: Path) -> str:
    """The bodies at the end, cut through the axis, coloured by body; '' when it cannot."""
    from impactsim.output.render import RenderError, render_series

    try:
        pngs = render_series(run_dir, field="body", cut=(np.array([0.0, 1.0, 0.0]), None), view="all",
                             out=run_dir / "render", window_size=(900, 700))
    except RenderError as err:
        print(f"no picture: {err}", flush=True)
        return ""
    target.parent.mkdir(parents=True, exist_ok=True)
    target.write_bytes(pngs[-1].read_bytes())
    return target.name


def row(name: str, s: dict) -> str:
    sh = s.get("shield", {})
    e0 = s["energy"]["total_energy"] / (1.0 + s["energy_balance_error"])  # at the start
    dist = s["fracture"].get("distortion", {}).get("deleted", 0)
    deleted = s["eroded_elements"]
    eroded = s["energy"]["eroded_energy"]
    perf = "/".join("yes" if p else "no" for p in sh.get("perforated", []))
    return (f"| {name} | {deleted} ({dist} by distortion) | {eroded:.3g} J "
            f"({100 * eroded / e0:.2g} %) | {1e3 * sh.get('d1', 0):.1f} | "
            f"{1e3 * sh.get('d2', 0):.1f} | {perf} | {s['fragments']['count']} "
            f"({s['fragments']['mesh_pieces']} mesh pieces) | "
            f"{100 * s['energy_balance_error']:+.2f} % | {s['_wall']:.0f} s |")


def main() -> int:
    sys.path.insert(0, str(ROOT))
    end = os.environ.get("COMPARE_END", "25 us")
    text = CASE.read_text()
    rows, pics = [], []
    for name, vt in variants(text).items():
        print(f"running: {name}", flush=True)
        s = reuse(name) if os.environ.get("COMPARE_REUSE") else run_variant(name, vt, end)
        rows.append(row(name, s))
        png = picture(s["_dir"], PICS / f"shield-{s['_dir'].name}.png")
        if png:
            pics.append(f"![{name} at {end}](fracture/{png})")
        print(rows[-1], flush=True)
    table = "\n".join([
        f"Generated by `make fracture-compare` (benchmarks/compare_fracture.py): "
        f"cases/three-plate-shield.toml on the coarse meshes of the tests (2 / 2.65 mm cells), "
        f"to {end}, one thread. Deleted: elements that left the mesh (erosion, distortion, "
        "conversion to particles); energy: what left with them, and its share of the initial "
        "energy (the sphere's kinetic energy); "
        "d1, d2: hole diameters of plates 1 and 2 [mm]; fragments: mesh pieces plus "
        "particles.", "",
        "| method | deleted elements | energy deleted | d1 [mm] | d2 [mm] | perforated 1/2/3 "
        "| fragments | energy balance | wall |",
        "| --- | --- | --- | --- | --- | --- | --- | --- | --- |", *rows, "",
        *[p + "\n" for p in pics]])
    doc = DOC.read_text()
    block = f"{BEGIN}\n{table}\n{END}"
    if BEGIN in doc:
        doc = doc[:doc.index(BEGIN)] + block + doc[doc.index(END) + len(END):]
    else:
        doc = doc.rstrip("\n") + "\n\n## Comparing the fracture methods on the shield\n\n" \
            + block + "\n"
    DOC.write_text(doc)
    print(f"wrote {DOC}", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
