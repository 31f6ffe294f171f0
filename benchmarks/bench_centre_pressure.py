"""Node separation's centred viscous heat with and without the pressure of the EOS at the
re-booked energy (SeparationPass.consistent_pressure, docs/fracture.md): the warm-up's block
dragged at 2 km/s (Mie-Grueneisen), tets (anp, tet4) and hexes, one thread. Prints the worst
and final energy balance error (of the largest KE + IE) and the largest |p - EOS(rho, e)| /
max(|p|, 0.1 GPa) of the intact loose elements after the pass (with anp the EOS reads the
averaged nodal volume, which this measure does not: tet4 and hexes only).

    python benchmarks/bench_centre_pressure.py [steps]
"""
import sys

import numba
import numpy as np

from impactsim.case import load_case_text
from impactsim.solver.build import build_model
from impactsim.solver.loop import Simulation
from impactsim.solver.pipeline import build_passes
from impactsim.fracture.separation import SeparationPass
from impactsim.materials import params as P
from impactsim.warmup import scenes



def mismatch(model, sp):
    worst = 0.0
    for s in sp.sep.sets:
        h = s.holder
        ids = s.q_ids
        ids = ids[h.status[ids] == 0]
        if not ids.shape[0]:
            continue
        mp = model.mat_params[h.elem_mat[ids]]
        rho0, g0 = mp[:, P.RHO0], mp[:, P.GAMMA0]
        # the stored p - b e against the EOS's energy-independent part a(rho)
        a_stored = h.pressure[ids] - g0 * rho0 * h.energy[ids]
        rho = h.elem_mass[ids] / h.vol[ids]
        eta = 1.0 - rho0 / rho
        c0, sc = mp[:, P.C0], mp[:, P.S]
        k = rho0 * c0 * c0
        den = np.maximum(1.0 - sc * np.maximum(eta, 0.0), 0.05)
        ph = np.where(eta > 0, k * eta / den**2, k * eta)
        a = ph * (1.0 - 0.5 * g0 * eta)
        rel = np.abs(a_stored - a) / np.maximum(np.abs(h.pressure[ids]), 1e8)
        worst = max(worst, float(np.max(rel)))
    return worst


def run(text, element, consistent, steps):
    case = load_case_text(text)
    model = build_model(case)
    kw = {"element": element} if element else {}
    sim = Simulation(model, build_passes(case, model), cfl=case.run.cfl,
                     cq=case.run.q_quadratic, cl=case.run.q_linear, **kw)
    sp = next(p for p in sim.fracture_passes if isinstance(p, SeparationPass))
    sp.consistent_pressure = consistent
    e = sim.energies()
    e0, ref, worst, last = e["total_energy"], abs(e["total_energy"]), 0.0, 0.0
    mm = 0.0
    for _ in range(steps):
        sim.step()
        mm = max(mm, mismatch(model, sp))
        e = sim.energies()
        ref = max(ref, e["kinetic_energy"] + e["internal_energy"])
        worst = max(worst, abs(e["total_energy"] - e0) / ref)
        last = (e["total_energy"] - e0) / ref
    return worst, last, (mm if element != "anp" else float("nan")), sp.sep.counts["new_nodes"]


def main(steps: int = 40) -> int:
    numba.set_num_threads(1)
    sc = dict((n, t) for n, t, _ in scenes())
    for name, element in (("separation", "anp"), ("separation", "tet4"),
                          ("separation-hex", None)):
        for consistent in (False, True):
            w, last, mm, nn = run(sc[name], element, consistent, steps)
            print(f"{name:16} {str(element):5} consistent={consistent!s:5} steps={steps} "
                  f"worst balance {100 * w:.2f} %  end {100 * last:+.2f} %  "
                  f"max |p - EOS|/|p| {mm:.2e}  new nodes {nn}", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main(int(sys.argv[1]) if len(sys.argv) > 1 else 40))
