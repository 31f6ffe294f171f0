"""Node separation: what depends on the connectivity after a release step, updated in place
(Surface.reconnect of the moved tets, fracture/separation_refresh.py: free faces, live-corner
counts, force rows) against built afresh (Surface.from_model, Boundary.from_model, force_rows).

The scene of tests/hard/test_separation_hard.py: a steel sphere at 2 km/s through a separable
Al plate of 24 x 24 x 2 mm at 1 mm (6,912 tets, every tet with its own node copies). The run is
made twice from the same start, once with each update; both give the same bits (tests/unit/
test_contact_surface.py), so the same release steps are timed. Prints ms per release step of
the surface update and of the whole refresh (surface, free faces, force rows, node-to-element
index) and the speed-ups, and the whole step time of both runs, on one thread. ``--hex``: the
plate in hexes (1,152; HexSurface.reconnect, ProxyTets.reconnect against their rebuild).
"""

from __future__ import annotations

import sys
import time

import numba

SCENE = """
[run]
name = "bench-reconnect"
end_time = "3 us"
[[material]]
name = "al"
library = "al-ideal-plastic"
failure = { fracture_strain = 1.0 }
[[body]]
name = "plate"
material = "al"
shape = "plate"
size = ["24 mm", "24 mm", "2 mm"]
position = ["0 mm", "0 mm", "-1 mm"]
mesh_size = "1 mm"
mesher = "structured"
[[body]]
name = "sphere"
material = "steel-4340"
shape = "sphere"
radius = "5 mm"
position = ["0 mm", "0 mm", "5.05 mm"]
mesh_size = "2 mm"
velocity = ["0 m/s", "0 m/s", "-2000 m/s"]
[contact]
self_contact = true
"""
STEPS = 200


def run(incremental: bool, hexes: bool = False):
    from impactsim.case import load_case_text
    from impactsim.contact.passes import ContactContext
    from impactsim.fracture.separation import SeparationPass
    from impactsim.solver.build import build_model
    from impactsim.solver.loop import Simulation
    from impactsim.solver.pipeline import build_passes

    text = SCENE.replace('mesher = "structured"', 'mesher = "structured"\nelement = "hex8"') \
        if hexes else SCENE
    case = load_case_text(text)
    model = build_model(case)
    sim = Simulation(model, build_passes(case, model), cfl=case.run.cfl)
    sp = next(p for p in sim.fracture_passes if isinstance(p, SeparationPass))
    sp.incremental = incremental
    spent = {"surface": 0.0, "calls": 0, "refresh": 0.0}
    real_refresh = sp.refresh

    def refresh(model_):
        t = time.perf_counter()
        real_refresh(model_)
        spent["refresh"] += time.perf_counter() - t
    sp.refresh = refresh
    for name in ("rebuild_surface", "reconnect_surface"):
        real = getattr(ContactContext, name)

        def timed(self, *a, _real=real):
            t = time.perf_counter()
            _real(self, *a)
            spent["surface"] += time.perf_counter() - t
            spent["calls"] += 1
        setattr(ContactContext, name, timed)
    t0 = time.perf_counter()
    for _ in range(STEPS):
        sim.step()
    wall = time.perf_counter() - t0
    return spent, wall, model, sp.sep.counts


def main() -> int:
    numba.set_num_threads(1)
    hexes = "--hex" in sys.argv[1:]  # the plate in hexes (HexSurface.reconnect)
    import impactsim.contact.passes as P

    originals = (P.ContactContext.rebuild_surface, P.ContactContext.reconnect_surface)
    run(True, hexes)  # compiles, loads the caches
    P.ContactContext.rebuild_surface, P.ContactContext.reconnect_surface = originals
    out = {}
    for incremental in (False, True):
        out[incremental] = run(incremental, hexes)
        P.ContactContext.rebuild_surface, P.ContactContext.reconnect_surface = originals
    (rs, rw, rm, rc), (is_, iw, im, _) = out[False], out[True]
    same = bool((rm.x == im.x).all() and (rm.v == im.v).all())
    n = max(rs["calls"], 1)
    n_hex = sum(b.conn.shape[0] for b in rm.blocks)
    print(f"{rm.n_elem} tets, {n_hex} hexes, {STEPS} steps, {rc['release_steps']} release steps, "
          f"{rc['new_nodes']} new nodes; same bits: {same}")
    print(f"{'surface update':<16}{'ms / release step':>20}{'whole run s':>14}")
    print(f"{'rebuild':<16}{1e3 * rs['surface'] / n:>20.2f}{rw:>14.2f}")
    print(f"{'reconnect':<16}{1e3 * is_['surface'] / max(is_['calls'], 1):>20.2f}{iw:>14.2f}")
    print(f"speed-up of the surface update: {rs['surface'] / max(is_['surface'], 1e-12):.1f}x")
    print(f"whole refresh, ms / release step: rebuilt {1e3 * rs['refresh'] / n:.2f}, in place "
          f"{1e3 * is_['refresh'] / max(is_['calls'], 1):.2f} "
          f"({rs['refresh'] / max(is_['refresh'], 1e-12):.1f}x)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
