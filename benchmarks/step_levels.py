"""Where a scene's time step comes from: how many parts of the tet kernel hold a stable step
near the global one, sampled every N steps.

The tet kernel reports the smallest stable step of each part of its mesh (`chunk_out[:,
OUT_DT]`, parts of 512 tets in kernel order); the global step is the smallest of them. When a
few parts set it and the median part could take a step several times longer, the scene pays
for a multi-rate scheme's worth of steps (docs/performance.md, "Whole scenes: what the step
costs").

    python benchmarks/step_levels.py [CASE] [--every 100] [--set KEY=VALUE ...]
"""

from __future__ import annotations

import argparse
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]


def main(argv=None) -> list[tuple]:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("case", nargs="?", default=str(ROOT / "cases" / "oblique-sphere.toml"))
    ap.add_argument("--every", type=int, default=100)
    ap.add_argument("--set", action="append", default=[], dest="sets")
    args = ap.parse_args(argv)

    from impactsim.case import load_case
    from impactsim.solver import element as E
    from impactsim.solver.loop import Simulation
    from impactsim.solver.run import run_case

    rows = []
    update = Simulation._update_elements

    def sampled(sim, dt):
        update(sim, dt)
        if dt > 0.0 and sim.model.step % args.every == args.every - 1:
            d = sim.chunk_out[:, E.OUT_DT]
            d = d[np.isfinite(d) & (d > 0.0)]
            m = d.min()
            rows.append((sim.model.step + 1, m, d.shape[0], int((d < 1.5 * m).sum()),
                         int((d < 2 * m).sum()), int((d < 3 * m).sum()), np.median(d) / m))

    Simulation._update_elements = sampled
    try:
        with tempfile.TemporaryDirectory() as out:
            run_case(load_case(Path(args.case), args.sets), Path(out), progress=False)
    finally:
        Simulation._update_elements = update
    print(f"{'step':>6}{'step ns':>9}{'parts':>7}{'<1.5x':>7}{'<2x':>6}{'<3x':>6}"
          f"{'median/min':>12}")
    for r in rows:
        print(f"{r[0]:6d}{r[1] * 1e9:9.2f}{r[2]:7d}{r[3]:7d}{r[4]:6d}{r[5]:6d}{r[6]:12.2f}")
    return rows


if __name__ == "__main__":
    main()
