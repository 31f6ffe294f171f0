"""A wrong run never ends quietly: the state and the energy balance watched every step.

After each step ``Watch.after_step(sim)`` runs one pass over the node and element arrays
(``state_sums``, a numba kernel: kinetic and internal energy, which the balance needs, and a
sum of ``value * 0`` over every position, velocity, force and specific energy, which is 0 when
all are finite and nan otherwise). Stress and pressure need no pass of their own: the element
update computed every live element's nodal forces from them in this step, and a nan or inf in
either makes those forces non-finite (nan * 0 and inf * 0 are nan), which the force test
catches. Leaving the six stress components and the pressure out (56 of the 73 bytes the pass
read per element) took the watch from 2.7-3.0 s of oblique-sphere's run to 1.1-1.2 s
(docs/performance.md, "Whole scenes, session 19"). Its cost is measured by
benchmarks/bench_watch.py (docs/user-guide.md, Stops). When the sum is not finite, a second
pass (``locate``) names the first node or element holding a non-finite value, its body and the
array, and the run stops with SimulationStopped in the step the value appeared (a value a pass
writes into an element's stress after the element update: in the next step, from its forces).

The total energy (kinetic + internal + dissipated + eroded - external work + the half-step
energy, as Simulation.energies: time-centred, so that a body driven from rest by a prescribed
velocity or an initial strain-rate field balances from its first step) is compared each step
with its initial value. The balance error is
(E - E0) / E_ref, with E_ref the largest of |E0| and the kinetic + internal energy seen so far
(a run driven by prescribed velocities starts at rest). The largest error is kept for the
summary; a gain beyond ``energy_limit`` is a wrong run (an unstable step, a bad contact) and,
by the case's [checks] energy_balance action, stops it or is reported.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from impactsim.model import ERODED

CHUNK = 4096


@numba.njit(cache=True)
def state_sums(x, v, force, mass, energy, elem_mass, status):
    """(kinetic energy, internal energy, finiteness sum, force power): the third is 0.0 when
    every value of the arrays is finite (the live elements' only), nan otherwise; the last the
    sum of F . v over the nodes with mass (nodal.force_power, for the time-centred balance).
    Sums in fixed chunks, the same on any thread count."""
    n = mass.shape[0]
    ke = 0.0
    bad = 0.0
    power = 0.0
    for c in range(0, n, CHUNK):
        s = 0.0
        p = 0.0
        for i in range(c, min(n, c + CHUNK)):
            s += mass[i] * (v[i, 0] * v[i, 0] + v[i, 1] * v[i, 1] + v[i, 2] * v[i, 2])
            bad += (x[i, 0] + x[i, 1] + x[i, 2] + force[i, 0] + force[i, 1] + force[i, 2]) * 0.0
            if mass[i] > 0.0:
                p += force[i, 0] * v[i, 0] + force[i, 1] * v[i, 1] + force[i, 2] * v[i, 2]
        ke += s
        power += p
    ke *= 0.5
    bad += ke * 0.0
    ie = 0.0
    for e in range(energy.shape[0]):
        if status[e] != ERODED:
            ie += elem_mass[e] * energy[e]
    bad += ie * 0.0  # a non-finite energy makes the sum non-finite
    return ke, ie, bad, power


def locate(model) -> str:
    """Where the first non-finite value of the state is: 'node 12 (body "bar"): velocity'."""
    m = model
    live = m.status != ERODED
    for name, arr in (("velocity", m.v), ("position", m.x), ("force", m.force)):
        bad = np.flatnonzero(~np.isfinite(arr).all(axis=1))
        if len(bad):
            i = int(bad[0])
            b = int(np.searchsorted(m.node_start, i, side="right") - 1)
            return (f"node {i} (body {m.body_names[b]!r}) has a non-finite {name} "
                    f"{arr[i].tolist()}" + (f" and {len(bad) - 1} more node(s)" if len(bad) > 1
                                            else ""))
    for name, arr in (("pressure", m.pressure), ("deviatoric stress", m.sdev),
                      ("specific internal energy", m.energy)):
        ok = np.isfinite(arr) if arr.ndim == 1 else np.isfinite(arr).all(axis=1)
        bad = np.flatnonzero(~ok & live)
        if len(bad):
            e = int(bad[0])
            return (f"element {e} (body {m.body_names[m.elem_body[e]]!r}) has a non-finite "
                    f"{name}" + (f" and {len(bad) - 1} more element(s)" if len(bad) > 1 else ""))
    return "the kinetic or internal energy overflowed (values beyond 1e308)"


class NonFinite(Exception):
    """A non-finite value in the state (the message says where and when)."""


class Watch:
    """Per-step health of a run: non-finite values and the energy balance."""

    def __init__(self, sim, energy_limit: float | None = 0.05):
        self.sim = sim
        self.energy_limit = energy_limit
        self.e0: float | None = None
        self.reference = 0.0
        self.worst = 0.0  # the largest balance error seen (signed: a gain is positive)
        self.worst_time = 0.0
        self.seconds = 0.0
        self.last = 0.0

    def sums(self) -> tuple[float, float, float, float]:
        m = self.sim.model
        return state_sums(m.x, m.v, m.force, m.mass, m.energy, m.elem_mass, m.status)

    def after_step(self) -> float:
        """Check the state; returns the energy balance error of this step. Raises NonFinite."""
        import time

        t0 = time.perf_counter()
        sim, m = self.sim, self.sim.model
        ke, ie, bad, power = self.sums()
        if not bad == 0.0:
            self.seconds += time.perf_counter() - t0
            raise NonFinite(f"non-finite state at t = {m.time:.6g} s (step {m.step}): "
                            f"{locate(m)}")
        # adds the element blocks' (hex) internal energy and the half-step energy
        terms = sim.energies(ke=ke, ie=ie, power=power)
        total, ie = terms["total_energy"], terms["internal_energy"]
        if self.e0 is None:
            self.e0 = total
        self.reference = max(self.reference, abs(self.e0), ke + ie)
        err = (total - self.e0) / self.reference if self.reference > 0.0 else 0.0
        if abs(err) > abs(self.worst):
            self.worst, self.worst_time = err, m.time
        self.last = err
        self.seconds += time.perf_counter() - t0
        return err

    def gaining(self) -> bool:
        """The balance shows an energy gain beyond the limit (this step)."""
        return self.energy_limit is not None and self.last > self.energy_limit

    def report(self) -> dict:
        return {"energy_balance_error_max": self.worst,
                "energy_balance_error_max_time": self.worst_time,
                "energy_reference": self.reference}


def describe_gain(watch: Watch) -> str:
    m = watch.sim.model
    return (f"total energy grew by {100 * watch.last:.3g} % of the reference energy "
            f"{watch.reference:.4g} J at t = {m.time:.6g} s (step {m.step}), beyond the "
            f"limit of {100 * watch.energy_limit:g} % (checks.energy_balance): an unstable "
            "step, a body starting inside another or a wall, or a contact that pushes")


def finite(x: float) -> bool:
    return math.isfinite(x)
