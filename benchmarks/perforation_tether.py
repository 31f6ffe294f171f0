"""Why a point of the perforation sweep (benchmarks/validate.py, PERFORATION) takes many more
steps than its neighbours and reads a small hole: runs one point, records every 100 steps the
element that sets the stable step (its body, status, plastic strain, damage, volume ratio,
shortest and longest edge), then measures the plate's hole on the last frame three ways: as
the summary does (the largest piece of all live cells, joined through shared nodes), without
the damaged cells, and without the cells stretched beyond five times the mean initial edge.

    python benchmarks/perforation_tether.py 400 1.2 1.0          # V_s, sphere h, plate h
    python benchmarks/perforation_tether.py 400 1.2 1.0 --distortion "0.5 us"

The second form adds distortion erosion (`[fracture] distortion_interval`). docs/validation.md
(the perforation sweep's reading) has the result for the fine 400 m/s point.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from collections import Counter
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "benchmarks"))


def record(sim, rows: list) -> None:
    """The step-limiting element's state (tets only)."""
    m, k = sim.model, int(sim.worst_element)
    if k < 0:
        return
    xs = m.x[m.conn[k]]
    edges = [float(np.linalg.norm(xs[i] - xs[j])) for i in range(4) for j in range(i + 1, 4)]
    rows.append({"t_us": 1e6 * m.time, "step": m.step, "dt_ns": 1e9 * sim.dt, "element": k,
                 "body": m.body_names[m.elem_body[k]], "status": int(m.status[k]),
                 "plastic_strain": float(m.eps_p[k]), "damage": float(m.damage[k]),
                 "volume_ratio": float(m.vol[k] / m.vol0[k]),
                 "shortest_edge_mm": 1e3 * min(edges), "longest_edge_mm": 1e3 * max(edges),
                 "z_mm": 1e3 * float(xs[:, 2].mean())})


def holes(out: Path, body: str = "plate") -> list[str]:
    """The plate's hole on the last frame, its largest piece taken three ways."""
    import meshio

    from impactsim.fracture.measures import hole_size, node_pieces

    m = meshio.read(sorted(out.glob("frame_*.vtu"))[-1])
    x = np.asarray(m.points)
    x0 = x - m.point_data["displacement"]
    conn = m.cells[0].data
    cd = {k: v[0] for k, v in m.cell_data.items()}
    names = json.loads((out / "summary.json").read_text())["bodies"]
    b = list(names).index(body)
    sel = cd["body"] == b
    nodes = np.unique(conn[sel])
    remap = -np.ones(len(x), dtype=np.int64)
    remap[nodes] = np.arange(len(nodes))
    c, st = remap[conn[sel]], cd["status"][sel]
    xp, x0p = x[nodes], x0[nodes]
    e01 = x0p[c[:, 1]] - x0p[c[:, 0]]
    h = float(np.sqrt((e01 * e01).sum(axis=1)).mean())
    longest = np.max([np.linalg.norm(xp[c[:, i]] - xp[c[:, j]], axis=1)
                      for i in range(4) for j in range(i + 1, 4)], axis=0)
    stretched = longest > 5.0 * h
    lines = [f"{body}: {len(c)} cells, status counts {np.bincount(st).tolist()}; cells longer "
             f"than 5 h = {5e3 * h:.1f} mm: {int(stretched.sum())} (status "
             f"{st[stretched].tolist()}, longest edges "
             f"{np.round(1e3 * longest[stretched], 1).tolist()} mm)"]
    for label, live in (("all live cells (the summary)", np.ones(len(c), bool)),
                        ("intact cells only", st == 0),
                        ("without the stretched cells", ~stretched)):
        lab, _ = node_pieces(c, live)
        counts = np.bincount(lab[lab >= 0])
        big = int(np.argmax(counts))
        hole = hole_size(xp, x0p, c, lab == big, h)
        low = 1e3 * xp[np.unique(c[lab == big])][:, 2].min()
        lines.append(f"  {label}: {len(counts)} pieces, the largest {counts[big]} cells reaching "
                     f"z = {low:.1f} mm; hole {1e3 * hole['diameter_equivalent']:.1f} mm")
    return lines


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("speed", type=float)
    ap.add_argument("h_sphere", type=float)
    ap.add_argument("h_plate", type=float)
    ap.add_argument("--distortion", metavar="INTERVAL",
                    help='add [fracture] distortion_interval (e.g. "0.5 us")')
    ap.add_argument("--out", type=Path, default=None)
    args = ap.parse_args(argv)

    import validate

    from impactsim.case import load_case_text
    from impactsim.solver import loop
    from impactsim.solver.run import run_case

    end = round(1e6 * 3 * (12.7e-3 + 4.9e-3) / args.speed + 10.0)
    text = validate.PERFORATION.format(speed=args.speed, end=end, hs=args.h_sphere,
                                       hp=args.h_plate)
    if args.distortion:
        text = text.replace("[fracture]\n",
                            f'[fracture]\ndistortion_interval = "{args.distortion}"\n')
    out = args.out or validate.OUT / (f"tether-{args.speed:.0f}-{args.h_plate}"
                                      + ("-distortion" if args.distortion else ""))
    rows: list = []
    step = loop.Simulation.step

    def recording_step(self, limit=float("inf")):
        dt = step(self, limit)
        if self.model.step % 100 == 0:
            record(self, rows)
        return dt

    loop.Simulation.step = recording_step
    cpu = time.process_time()
    try:
        s = run_case(load_case_text(text), out, progress=False)
    finally:
        loop.Simulation.step = step
    cpu = time.process_time() - cpu
    v = s["bodies"]["sphere"]["residual_velocity"]
    print(f"V_s {args.speed:.0f} m/s, h {args.h_sphere} / {args.h_plate} mm"
          + (f", distortion erosion every {args.distortion}" if args.distortion else "")
          + f": {s['steps']:,} steps, {cpu:.0f} CPU s, residual {-v[2]:.1f} m/s, "
          f"hole {1e3 * s['bodies']['plate']['hole']['diameter_equivalent']:.1f} mm, "
          f"eroded {s['fracture'].get('eroded_total', 0) if s['fracture'] else 0}")
    limiting = Counter((r["element"], r["body"]) for r in rows)
    print("step-limiting elements (element, body): samples of 100 steps:",
          limiting.most_common(4))
    for r in rows[::max(1, len(rows) // 12)]:
        print("  " + ", ".join(f"{k} {v:.3g}" if isinstance(v, float) else f"{k} {v}"
                               for k, v in r.items()))
    for line in holes(out):
        print(line)
    (out / "step_limit.json").write_text(json.dumps(rows))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
