"""Where a scene's time step comes from: how many parts of the tet kernel hold a stable step
near the global one, sampled every N steps.

The tet kernel reports the smallest stable step of each part of its mesh (`chunk_out[:,
OUT_DT]`, parts of 512 tets in kernel order); the global step is the smallest of them. When a
few parts set it and the median part could take a step several times longer, the scene pays
for a multi-rate scheme's worth of steps (docs/performance.md, "Whole scenes: what the step
costs").

It also says what a subcycling scheme could spare of the element updates (the `levels`
columns): each part updated every 2^k steps, k <= --max-level the largest level whose interval
still fits its own stable step, so the element work of a step is the mean of 2^-k over the
parts. Two bounds: with the step constant over an interval ("const"), and with the step
growing by the loop's DT_GROWTH at every step of it ("grow", the worst the time loop allows);
each for parts of 512 tets and of 2,048 (four chunks, the tet kernel's unit of work and of
force rows). An estimate from the stable steps alone: it leaves out what a scheme would pay
to keep levels and to bring a part up to date when one of its elements erodes.

    python benchmarks/step_levels.py [CASE] [--every 100] [--max-level 3] [--set KEY=VALUE ...]
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
    ap.add_argument("--max-level", type=int, default=3)
    ap.add_argument("--set", action="append", default=[], dest="sets")
    args = ap.parse_args(argv)

    from impactsim.case import load_case
    from impactsim.solver import element as E
    from impactsim.solver.loop import DT_GROWTH, Simulation
    from impactsim.solver.run import run_case

    k_all = np.arange(args.max_level + 1)
    # the longest interval of 2^k steps of the loop's step dt, in units of dt
    span = {"const": 2.0 ** k_all,
            "grow": np.array([(DT_GROWTH ** (2 ** k) - 1.0) / (DT_GROWTH - 1.0) for k in k_all])}

    def work(d, m):
        """The element work of a step, a share of the full update, for part steps d and
        global step m (both the stable steps: the loop's step is cfl times either)."""
        out = []
        for size in (1, 4):
            n = (d.shape[0] + size - 1) // size * size
            p = np.full(n, np.inf)
            p[:d.shape[0]] = d
            p = p.reshape(-1, size).min(axis=1)
            for key in ("const", "grow"):
                fits = span[key][None, :] * m <= p[:, None]
                level = np.where(fits, k_all[None, :], 0).max(axis=1)
                out.append(float(np.mean(2.0 ** -level)))
        return out

    rows = []
    update = Simulation._update_elements

    def sampled(sim, dt):
        update(sim, dt)
        if dt > 0.0 and sim.model.step % args.every == args.every - 1:
            part_dt = sim.chunk_out[:, E.OUT_DT]
            d = part_dt[np.isfinite(part_dt) & (part_dt > 0.0)]
            m = d.min()
            rows.append((sim.model.step + 1, m, d.shape[0], int((d < 1.5 * m).sum()),
                         int((d < 2 * m).sum()), int((d < 3 * m).sum()), np.median(d) / m,
                         *work(np.where(part_dt > 0.0, part_dt, np.inf), m)))

    Simulation._update_elements = sampled
    try:
        with tempfile.TemporaryDirectory() as out:
            run_case(load_case(Path(args.case), args.sets), Path(out), progress=False)
    finally:
        Simulation._update_elements = update
    print(f"{'step':>6}{'step ns':>9}{'parts':>7}{'<1.5x':>7}{'<2x':>6}{'<3x':>6}"
          f"{'median/min':>12}   element work with levels: 512 const, grow; 2048 const, grow")
    for r in rows:
        print(f"{r[0]:6d}{r[1] * 1e9:9.2f}{r[2]:7d}{r[3]:7d}{r[4]:6d}{r[5]:6d}{r[6]:12.2f}"
              f"   {r[7]:6.2f} {r[8]:6.2f}  {r[9]:6.2f} {r[10]:6.2f}")
    if rows:
        mean = np.mean(np.array([r[7:] for r in rows]), axis=0)
        print(f"mean over the samples (max level {args.max_level}): 512 tets {mean[0]:.2f} "
              f"(const) {mean[1]:.2f} (grow); 2048 tets {mean[2]:.2f} (const) {mean[3]:.2f} "
              f"(grow) of the element updates")
    return rows


if __name__ == "__main__":
    main()
