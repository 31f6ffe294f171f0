"""PySPH's packaged solid-mechanics Taylor bar at one particle spacing (run by benchmarks/peers.py
inside the peers' virtual environment, which has PySPH and not impactsim).

The problem is PySPH's own `pysph/examples/solid_mech/taylor_bar.py`, unchanged but for the
particle spacing: a 2-D (plane strain) steel bar 7.6 mm wide and 25.4 mm long at 200 m/s onto a
wall of boundary particles, von Mises plasticity (600 MPa), Mie-Grueneisen EOS, 25 us, with the
example's fixed time step of 1 ns. The spacing `dx` (and everything the example derives from it:
smoothing length, particle mass, the wall's particles) is set before the particles are made; the
example's default is 0.384848 mm.

Prints one JSON line: spacing, particles, steps, wall and CPU seconds of the solve (the
Cython build of the equations, which PySPH caches in ~/.pysph, is done in setup() and not
counted), and the bar's final length: the extent of the bar's particles along the impact axis
plus one spacing (each particle stands for a dx-wide strip; the initial value is 25.4 mm).
"""

from __future__ import annotations

import argparse
import json
import tempfile
import time


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--dx", type=float, required=True, help="particle spacing [m]")
    parser.add_argument("--tf", type=float, default=None, help="end time [s] (default: the example's)")
    args = parser.parse_args()

    from pysph.examples.solid_mech import taylor_bar as tb

    tb.dx = tb.dy = args.dx
    tb.h = tb.hdx * args.dx
    tb.m0 = args.dx * args.dx * tb.r0

    argv = ["--disable-output", "-q", "--no-openmp"]
    if args.tf is not None:
        argv += ["--tf", repr(args.tf)]
    with tempfile.TemporaryDirectory() as out:
        app = tb.TaylorBar(output_dir=out)
        app.setup(argv)
        wall, cpu = time.perf_counter(), time.process_time()
        app.solver.solve(show_progress=False)
        wall, cpu = time.perf_counter() - wall, time.process_time() - cpu
        bar = next(pa for pa in app.particles if pa.name == "bar")
        y = bar.get("y")
        print(json.dumps({
            "code": "PySPH", "dx": args.dx, "particles": int(len(y)),
            "steps": int(app.solver.count), "wall_seconds": wall, "cpu_seconds": cpu,
            "length": float(y.max() - y.min() + args.dx),
        }))


if __name__ == "__main__":
    main()
