"""Coulomb friction (stick and slip) on the contact interfaces of the Schwarz iteration and
of the monolithic check.

Each contact node m of the kinematic side A has a tangent frame t_1, t_2 (orthonormal, normal
to n_m). Per interface with a friction coefficient mu > 0 (``Tangential``):

- ``C_t`` (2n x 3 N_A): rows t_k . u_A(m), k-major (row k n + m);
- ``I_t`` (2n x 3 N_B): rows t_k . u_B(s_m), B's displacement at the matching point;
- ``G_t`` (3 N_B x 2n): B's nodal forces of the traction sum_m phi_m q_km t_km, q interpolated
  from A's nodal tangential tractions (the same mortar-like transfer as the pressure's).

The tangential traction on A is -q (q_1 t_1 + q_2 t_2 at each node), on B +q, so q is the
friction force A exerts on B. Every active node is either

- **stick**: A's tangential displacement is prescribed, t_k . u_A(m) = g_k, as rows beside the
  normal row (the same Schur complement: `body.BodyState` stacks C_a and C_t); the stick
  condition is that the relative tangential displacement w = t . (u_A - u_B(s)) keeps the value
  s it had when the node stuck (zero in the reference state), and [G15]'s eq. 7 relaxes g
  towards t . u_B(s) + s like the normal g. q = M_ss^-1 lambda_t (the stick rows'
  multipliers) as p = M^-1 lambda;
- **slip**: no tangential row; A and B are loaded by the traction |q| = mu p along the slip
  direction d, q = mu max(p, 0) d. A's nodal forces are -C_t^T (M q) on its active nodes.

The stick/slip set is updated with the active set (when the iteration has settled for the
current sets, ``schwarz.SETTLE``): a stick node whose |q| exceeds mu p slips, along q; a slip
node whose slip increment in the load step (w - w at the step's start) turns against d sticks
where it is; d follows the slip increment. Nodes that close stick. mu = inf: every active node
sticks for good (tied tangentially); mu = 0 (the default): no tangential rows, the tangential
slip is free (frictionless).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from impactsim.quasistatic.coupling import Interface, _vectorise, surface_interpolation, \
    transfer_matrix
from impactsim.quasistatic.space import Space

SLIP = 1e-3  # a stick node slips when |q| > (1 + SLIP) mu p
TURN = 1e-6  # a slip increment below TURN x the largest displacement sets no direction


@dataclass
class Tangential:
    mu: float
    frame: np.ndarray  # (n, 2, 3) t_1, t_2 per contact node of A
    C_t: sp.csr_matrix  # (2n, 3 N_A)
    I_t: sp.csr_matrix  # (2n, 3 N_B)
    G_t: sp.csr_matrix  # (3 N_B, 2n)


@dataclass
class FrictionState:
    """Per interface with friction; arrays over A's contact nodes, tangential ones (2n,)
    k-major."""

    stick: np.ndarray  # (n,) bool
    g: np.ndarray  # (2n,) A's prescribed tangential displacement at stick nodes
    s: np.ndarray  # (2n,) the relative tangential displacement a stick node keeps
    s_step: np.ndarray  # (2n,) w at the start of the load step: slip increments start here
    q: np.ndarray  # (2n,) nodal tangential tractions (the force of A on B)
    d: np.ndarray  # (n, 2) slip directions in the frame
    turned: np.ndarray  # (n,) bool: d was turned round since the node slipped
    loaded: np.ndarray | None = None  # (n,) bool: p > 0 (the monolithic's slip tractions)


def frame(normals: np.ndarray) -> np.ndarray:
    """(n, 2, 3): t_1 = e x n normalised (e the axis least aligned with n), t_2 = n x t_1."""
    e = np.eye(3)[np.argmin(np.abs(normals), axis=1)]
    t1 = np.cross(e, normals)
    t1 /= np.linalg.norm(t1, axis=1)[:, None]
    t2 = np.cross(normals, t1)
    return np.stack([t1, t2], axis=1)


def attach(itf: Interface, sa: Space, sb: Space) -> None:
    """Build itf.tangential when the interface has friction (mu > 0)."""
    if not itf.friction > 0:
        return
    t = frame(itf.normals)
    n = len(itf.nodes)
    Sa = sp.csr_matrix((np.ones(n), (np.arange(n), itf.nodes)), shape=(n, sa.n))
    Pb, _, _ = surface_interpolation(sb, itf.facets_b, itf.points)
    xa, _ = sa.facet_geometry(itf.facets_a)
    area = 0.5 * np.linalg.norm(np.cross(xa[:, 1] - xa[:, 0], xa[:, 2] - xa[:, 0]), axis=1)
    h = np.sqrt(area.mean())
    C_t = sp.vstack([_vectorise(Sa, t[:, k]) for k in range(2)]).tocsr()
    I_t = sp.vstack([_vectorise(Pb, t[:, k]) for k in range(2)]).tocsr()
    G_t = sp.hstack([transfer_matrix(sa, itf.facets_a, itf.nodes, sb, itf.facets_b, h,
                                     directions=t[:, k]) for k in range(2)]).tocsr()
    itf.tangential = Tangential(float(itf.friction), t, C_t, I_t, G_t)


def initial(interfaces: list[Interface], active: list[np.ndarray]) -> list:
    out = []
    for itf, act in zip(interfaces, active):
        if itf.tangential is None:
            out.append(None)
            continue
        n = len(itf.nodes)
        z = np.zeros(2 * n)
        out.append(FrictionState(act.copy(), z.copy(), z.copy(), z.copy(), z.copy(),
                                 np.zeros((n, 2)), np.zeros(n, bool)))
    return out


def begin_step(fstates: list) -> None:
    """A new load step: slip increments are measured from here."""
    for fs in fstates:
        if fs is not None:
            fs.s_step = fs.s.copy()


def _two(mask: np.ndarray) -> np.ndarray:
    return np.concatenate([mask, mask])


def slip_traction(mu: float, p: np.ndarray, d: np.ndarray) -> np.ndarray:
    """(2n,) q = mu max(p, 0) d at every node (the caller masks the slip nodes)."""
    if not np.isfinite(mu):
        return np.zeros(2 * len(p))
    return (mu * np.maximum(p, 0.0)[:, None] * d).T.ravel()


# --- the Schwarz iteration (schwarz.mechanics_phase calls these) ---

def add_inputs(inputs: dict, interfaces: list[Interface], state) -> None:
    """Extend the per-body inputs of an iteration: at friction interfaces A gets the stick
    rows' prescribed values (its g and active arrays become [normal, t_1, t_2]) and the slip
    tractions (a fourth dict), B the tangential tractions beside the pressures."""
    for key in inputs:
        if len(inputs[key]) == 3:
            inputs[key] = inputs[key] + ({},)
    for c, itf in enumerate(interfaces):
        fs = state.friction[c] if state.friction else None
        if fs is None:
            continue
        ga, aa, _, slip = inputs[itf.a][:4]
        ga[c] = np.concatenate([state.g[c], fs.g])
        aa[c] = np.concatenate([state.active[c], _two(fs.stick)])
        slipping = _two(state.active[c] & ~fs.stick)
        slip[c] = np.where(slipping, fs.q, 0.0)
        pb = inputs[itf.b][2]
        pb[c] = np.concatenate([state.p[c], np.where(_two(state.active[c]), fs.q, 0.0)])


@dataclass
class Measure:
    residuals: list  # per friction interface: stick residual (2n,)
    gap: float  # largest |r_t| / u_scale
    change: float  # largest |q - q_old| / p_scale
    changed: bool  # a stick/slip set or a direction changed


def measure(interfaces, state, out, pa_all, new_active, settle: bool, u_scale: float,
            p_scale: float) -> tuple[Measure, list]:
    """The tangential residuals and the new tractions and stick/slip sets of an iteration
    (applied by `advance` once the relaxation is known)."""
    m = Measure([], 0.0, 0.0, False)
    pending = []
    for c, itf in enumerate(interfaces):
        fs = state.friction[c] if state.friction else None
        if fs is None:
            pending.append(None)
            continue
        ua_t, q_stick = out[itf.a][("at", c)]
        ub_t = out[itf.b][("bt", c)]
        r = np.where(_two(fs.stick), ub_t + fs.s - fs.g, 0.0)
        m.residuals.append(r)
        m.gap = max(m.gap, np.max(np.abs(r), initial=0) / u_scale)
        stick, d, changed, turned = _sets(itf.tangential, fs, state.active[c], new_active[c],
                                  pa_all[c], q_stick, ua_t - ub_t, u_scale, p_scale, settle)
        m.changed |= changed
        s = np.where(_two(stick & fs.stick), fs.s, ua_t - ub_t)  # others stick where they are
        q = _tractions(itf.tangential, stick, new_active[c], q_stick, pa_all[c], d)
        m.change = max(m.change, np.max(np.abs(q - fs.q), initial=0) / p_scale)
        pending.append((stick, s, q, d, turned, ub_t, r))
    return m, pending


def _sets(T: Tangential, fs: FrictionState, act: np.ndarray, new_act: np.ndarray,
          p: np.ndarray, q_stick: np.ndarray, w: np.ndarray, u_scale: float, p_scale: float,
          settle: bool = True):
    """(stick set for the next solve, slip directions, whether a set or a direction changed,
    the nodes whose d was turned round) from a solve with the active set `act` and stick set
    fs.stick (within act); new_act is the next active set. Nodes that close stick; on settled
    iterates (`settle`) a stick node with |q| > mu p slips along q, d follows the slip
    increment, and a slip node moving against d a second time sticks."""
    stick = fs.stick & act & new_act
    d = fs.d.copy()
    turned = fs.turned.copy()
    changed = False
    if settle:  # decided on settled iterates only, as the release of the active set
        qv = q_stick.reshape(2, -1).T
        qn = np.linalg.norm(qv, axis=1)
        go = stick & (qn > (1 + SLIP) * _cap(T.mu, p) + 1e-12 * p_scale)
        d[go] = qv[go] / np.maximum(qn[go], 1e-300)[:, None]
        turned[go] = False
        changed = bool(go.any())
        stick = stick & ~go
        slip = act & ~fs.stick & new_act
        inc = (w - fs.s_step).reshape(2, -1).T
        incn = np.linalg.norm(inc, axis=1)
        # a slip node moving against d turns d round the first time (d came from the stick
        # tractions of an unconverged iterate) and sticks the second; a node without pressure
        # has no friction to stick with
        against = slip & (np.einsum("ij,ij->i", inc, fs.d) < -TURN * u_scale)
        back = against & fs.turned & (p > 0)
        turn = slip & ~back & (incn > TURN * u_scale)
        new_d = inc[turn] / incn[turn][:, None]
        changed |= bool(back.any()) or \
            (len(new_d) > 0 and np.max(np.abs(new_d - fs.d[turn])) > 1e-3)
        d[turn] = new_d
        turned = (turned | against) & ~back
        stick = stick | back
    return stick | (new_act & ~act), d, changed, turned


def _cap(mu: float, p: np.ndarray) -> np.ndarray:
    """mu max(p, 0); infinite for mu = inf (stuck, even without pressure)."""
    if not np.isfinite(mu):
        return np.full(len(p), np.inf)
    return mu * np.maximum(p, 0.0)


def _tractions(T: Tangential, stick, act, q_stick, p, d) -> np.ndarray:
    return np.where(_two(stick), q_stick, 0.0) + \
        np.where(_two(act & ~stick), slip_traction(T.mu, p, d), 0.0)


def advance(state, pending: list, omega) -> None:
    """Eq. 7 of [G15] for the stick rows: g <- g + omega r; other nodes' g is where A is."""
    for c, pend in enumerate(pending):
        if pend is None:
            continue
        fs = state.friction[c]
        stick, s, q, d, turned, ub_t, r = pend
        keep = _two(stick & fs.stick)
        om = omega[c] if np.ndim(omega) else omega
        fs.g = np.where(keep, fs.g + om * r, ub_t + s)
        fs.stick, fs.s, fs.q, fs.d, fs.turned = stick, s, q, d, turned


def resultants(itf: Interface, fs: FrictionState | None, p: np.ndarray,
               active: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(normal force, tangential force) vectors A exerts on B: sum of M p n and M q t over the
    active nodes."""
    idx = np.nonzero(active)[0]
    M = itf.M_a[idx][:, idx]
    normal = ((M @ p[idx])[:, None] * itf.normals[idx]).sum(axis=0)
    tang = np.zeros(3)
    if fs is not None:
        T = itf.tangential
        qv = fs.q.reshape(2, -1).T[idx]
        for k in range(2):
            tang += ((M @ qv[:, k])[:, None] * T.frame[idx, k]).sum(axis=0)
    return normal, tang


# --- the monolithic check ---

def monolithic_blocks(states, interfaces, active, fstates, lam_slices, off, m, add):
    """Add the friction rows and columns to the monolithic system: the stick rows of A
    (multipliers lambda_t, q = M_ss^-1 lambda_t, B loaded by G_t q) and the slip tractions
    mu p d, linear in the normal multipliers (p = M_aa^-1 lambda). Returns (the right-hand
    sides of the stick rows, their (offset, stick nodes) per interface, the new size)."""
    rhs, slices = [], []
    for c, itf in enumerate(interfaces):
        fs = fstates[c] if fstates else None
        if fs is None:
            slices.append(None)
            continue
        T = itf.tangential
        n = len(itf.nodes)
        m0, idx = lam_slices[c]
        st = np.nonzero(fs.stick & active[c])[0]
        sl = np.nonzero(active[c] & ~fs.stick)[0]
        ea, eb = states[itf.a].elastic, states[itf.b].elastic
        Maa = itf.M_a[idx][:, idx].toarray()
        P = np.linalg.inv(Maa) if len(idx) else np.zeros((0, 0))
        pos = np.searchsorted(idx, sl)
        slices.append((m, st))
        for k in range(2):
            if len(sl) and np.isfinite(T.mu):
                # q_k(slip) of lambda: mu p d where the last pass had p > 0 (the iteration's
                # mu max(p, 0) d)
                on = fs.loaded[sl] if fs.loaded is not None else np.ones(len(sl), bool)
                Q = sp.csr_matrix((T.mu * on * fs.d[sl, k])[:, None] * P[pos])
                Ma = itf.M_a[idx][:, sl]
                add((T.C_t[k * n + idx][:, ea.F].T @ (Ma @ Q)), off[itf.a], m0)
                add(-(T.G_t[:, k * n + sl][eb.F] @ Q), off[itf.b], m0)
            if len(st):
                rows = k * n + st
                Ct, It = T.C_t[rows], T.I_t[rows]
                Mss = itf.M_a[st][:, st].toarray()
                add(Ct[:, ea.F].T, off[itf.a], m)
                add(-(T.G_t[:, rows][eb.F] @ sp.csr_matrix(np.linalg.inv(Mss))), off[itf.b], m)
                add(Ct[:, ea.F], m, off[itf.a])
                add(-It[:, eb.F], m, off[itf.b])
                rhs.append(fs.s[rows] - Ct[:, ea.D] @ states[itf.a].uD
                           + It[:, eb.D] @ states[itf.b].uD)
                m += len(st)
    return rhs, slices, m


def monolithic_update(interfaces, fstates, slices, x, u, lam, active, new_active,
                      u_scale) -> bool:
    """After a monolithic solve with `active`: the tractions q, then the stick/slip sets for
    `new_active` by the rules of the iteration. True when a set or a direction changed."""
    changed = False
    p_scale = max(max((np.max(np.abs(q), initial=0) for q in lam), default=0.0), 1e-30)
    for c, itf in enumerate(interfaces):
        fs = fstates[c] if fstates else None
        if fs is None:
            continue
        T = itf.tangential
        n = len(itf.nodes)
        m0, st = slices[c]
        q_stick = np.zeros(2 * n)
        if len(st):
            Mss = itf.M_a[st][:, st].toarray()
            for k in range(2):
                q_stick[k * n + st] = np.linalg.solve(Mss, x[m0 + k * len(st):
                                                             m0 + (k + 1) * len(st)])
        w = T.C_t @ u[itf.a] - T.I_t @ u[itf.b]
        stick, d, ch, fs.turned = _sets(T, fs, active[c], new_active[c], lam[c], q_stick, w,
                                        u_scale, p_scale)
        loaded = lam[c] > 0
        if fs.loaded is not None:
            slip = active[c] & ~fs.stick
            ch |= bool((loaded != fs.loaded)[slip].any())
        fs.loaded = loaded
        changed |= ch
        fs.q = _tractions(T, fs.stick & active[c], active[c], q_stick, lam[c], fs.d)
        fs.s = np.where(_two(stick & fs.stick), fs.s, w)
        fs.stick, fs.d = stick, d
    return changed
