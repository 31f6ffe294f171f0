"""The alternating Schwarz iteration of [G15] over all bodies of a problem, one load step.

Heat first (one-way coupling): every body is solved with the exchange h (T - T_other) on its
contact facets, T_other the neighbour's temperature of the previous iteration at the matching
points (a Robin-Robin Jacobi iteration), until the interface temperatures stop changing.

Mechanics, per iteration k (all bodies at once, in parallel):
1. kinematic side A of each interface: the normal displacement of its active contact nodes is
   prescribed, u_m . n = g_m; its reactions give the nodal pressures p (force half-step input);
2. force side B: loaded by the pressures A gave at iteration k - 1 (traction -p n_B);
3. eq. 7 of [G15]: g_m <- g_m + omega (u_s . n + delta_m - g_m), u_s the displacement of the
   matching point of B; omega fixed, or Aitken's (Irons-Tuck) update of it from the last two
   residuals, restarted when the active set changes;
4. active set: an active node whose pressure turns tensile is released; an inactive node that
   penetrates B is activated (compressive-only contact).
It stops when the gap mismatch max |u_s . n + delta - g| (relative to the largest displacement)
and the pressure mismatch max |p_k - p_{k-1}| (relative to the largest pressure) are both
below their tolerances with an unchanged active set.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import scipy.linalg
import scipy.sparse as sp

from impactsim.quasistatic import friction
from impactsim.quasistatic.coupling import Interface
from impactsim.quasistatic.model import Settings


SETTLE = 10.0  # the active set is updated when the mismatches are below SETTLE x tolerance
MAX_INNER = 100  # ... or after this many iterations with the same active set
ACTIVATE = 10.0  # a node is activated when it penetrates by ACTIVATE x gap tolerance x u_max
# (on a Robin interface too: 100 there halved the 100-pellet stack's iterations but let an
# inactive node end 56 um inside the tube; docs/quasistatic.md, Known limits)
ENTER_FRACTION = 0.1  # penetrating nodes enter within this fraction of the penetrations'
# spread from the deepest, after a drop (update_active)
RELEASE = 1e-3  # a node is released when its (smoothed) pressure is below -RELEASE p_max
CHATTER = 2.0  # a Robin node's entry threshold grows by this factor each time it is released


ROTATIONS = True  # all six rigid modes on the anchor tree (session 9: 50 pellets converge)


class NotConverged(Exception):
    pass


@dataclass
class ContactState:
    g: list[np.ndarray]
    active: list[np.ndarray]
    p: list[np.ndarray]
    ua: list[np.ndarray] = field(default_factory=list)
    ub: list[np.ndarray] = field(default_factory=list)
    friction: list = field(default_factory=list)  # friction.FrictionState or None per interface
    # Robin interfaces: B's target t_B = delta - u_A . n and the pressure p_B that A gets
    # (state.g is A's target, state.p the pressure B gets, as on the other interfaces)
    tb: list = field(default_factory=list)
    pb: list = field(default_factory=list)
    # Robin interfaces: how often each node was released (its entry threshold grows with it)
    leaves: list = field(default_factory=list)


def update_active(itf: Interface, act: np.ndarray, p: np.ndarray, penetration: np.ndarray,
                  pen_tol: float, p_scale: float, release: bool = True) -> np.ndarray:
    """Compressive-only contact: release active nodes in tension, activate penetrating ones.
    The nodal pressures M^-1 lambda oscillate in sign where the pressure varies fast, so the
    release looks at them smoothed over each node's neighbours (weights |M|)."""
    if itf.tied:
        return act
    enter = (~act) & itf.matched & (penetration > pen_tol)
    pe = penetration[enter]
    if enter.any() and pe.min() > pe.max() - pe.min():
        # a drop: every penetrating node is deeper than the spread of their penetrations.
        # A body held at a point (the Hertz sphere on its pole node, its first iterate) sinks
        # on its weak springs far below the surface and its whole patch penetrates, by the
        # drop less each node's gap; nodes leave only once per settled state (100 iterations
        # for every few nodes there), so only those nearest the surface enter
        enter &= penetration >= pe.max() - ENTER_FRACTION * (pe.max() - pe.min())
    if not release:  # between settled states only nodes that penetrate enter
        return act | enter
    if itf.order == 1:
        # tet4: the nodal reactions themselves (M_aa p) say which nodes pull
        idx = np.nonzero(act)[0]
        lam = np.zeros(len(p))

        def restricted():
            M = itf.M_a if not itf.robin else sp.diags(np.asarray(itf.M_a.sum(axis=1)).ravel())
            return M.tocsr()[idx][:, idx]
        lam[idx] = _cached(itf, "mass", act.tobytes(), restricted) @ p[idx]
        scale = max(np.max(np.abs(lam), initial=0), 1e-300)
        release = act & (lam < -RELEASE * scale)
    else:
        Mabs = abs(itf.M_a)
        smooth = (Mabs @ np.where(act, p, 0.0)) / np.maximum(Mabs @ act.astype(float), 1e-300)
        release = act & (smooth < -RELEASE * p_scale)
    return (act & ~release) | enter


def max_penetration(interfaces, state: ContactState) -> float:
    """The deepest node [m] left out of a compressive-only contact by the last iterate (below
    its entry threshold, update_active): ua - (ub + gap) on the inactive matched nodes."""
    deepest = 0.0
    for c, itf in enumerate(interfaces):
        if not itf.tied and len(state.ua):
            pen = state.ua[c] - state.ub[c] - itf.gap
            deepest = max(deepest, float(np.max(pen, where=itf.matched & ~state.active[c],
                                                initial=0.0)))
    return deepest


def _anchor_tree(interfaces, active) -> tuple[dict, list]:
    """({body: its anchor interface}, those bodies ordered leaves first, the bodies whose
    anchor is their only closed kinematic contact). Only anchors with active nodes count (an open anchor carries
    nothing)."""
    parent = {}
    for c, itf in enumerate(interfaces):
        if itf.anchor and active[c].any():
            parent[itf.a] = c
    depth: dict = {}
    for body in parent:
        chain, x = [], body
        while x in parent and x not in depth and len(chain) <= len(parent):
            chain.append(x)
            x = interfaces[parent[x]].b
        d = depth.get(x, 0)
        for y in reversed(chain):
            d += 1
            depth[y] = d
    # bodies whose anchor is their only closed kinematic contact: what they carry goes to
    # the anchor alone, moments included (elsewhere the side contacts share it by stiffness)
    others = {itf.a for c, itf in enumerate(interfaces)
              if not itf.anchor and active[c].any()}
    # a body on an active Robin contact shares every change with that spring
    others |= {itf.b for c, itf in enumerate(interfaces) if itf.robin and active[c].any()}
    alone = {b for b in parent if b not in others}
    return parent, sorted(parent, key=lambda x: -depth[x]), alone


def _rigid_rows(points: np.ndarray, normals: np.ndarray, centre: np.ndarray) -> np.ndarray:
    """(n, 6): n_m . (t + theta x (x_m - centre)) for t, theta."""
    r = points - centre
    return np.hstack([normals, np.cross(r, normals)])


def _cached(itf: Interface, name: str, key, build):
    """A per-interface operator that depends only on the active set (and a flag): computed
    once per active set instead of at every iteration (the per-body least-squares fits were
    a quarter of the coordinator's time per iteration)."""
    cache = itf.__dict__.setdefault("_coarse_cache", {})
    hit = cache.get(name)
    if hit is None or hit[0] != key:
        hit = (key, build())
        cache[name] = hit
    return hit[1]


def _origin_rows(itf: Interface) -> np.ndarray:
    """(n, 6): n_m . (t + theta x x_m) at the interface's points, (t, theta) about the origin."""
    cache = itf.__dict__.setdefault("_coarse_cache", {})
    if "origin" not in cache:
        cache["origin"] = np.hstack([itf.normals, np.cross(itf.points, itf.normals)])
    return cache["origin"]


def _fit_motion(itf: Interface, act: np.ndarray, rotations: bool) -> np.ndarray:
    """(6, n_active): the least-squares rigid motion (about the origin) whose normal
    displacement at the active nodes fits a given one; translations only unless `rotations`."""
    def build():
        x, n = itf.points[act], itf.normals[act]
        centre = x.mean(axis=0)
        A = _rigid_rows(x, n, centre)
        scale = np.sqrt((np.linalg.norm(x - centre, axis=1) ** 2).mean()) or 1.0
        A[:, 3:] /= scale
        if not rotations:
            A[:, 3:] = 0.0
        P = np.linalg.pinv(A, rcond=1e-8)  # (6, n): the minimum-norm least-squares fit
        P[3:] /= scale
        T = np.eye(6)  # about the centre -> about the origin: t - theta x centre
        T[:3, 3:] = np.array([[0, -centre[2], centre[1]], [centre[2], 0, -centre[0]],
                               [-centre[1], centre[0], 0]])
        return T @ P
    return _cached(itf, "motion", (act.tobytes(), rotations), build)


def _fit_pressure(itf: Interface, act: np.ndarray, rotations: bool) -> np.ndarray:
    """(n_active, 6): the pressure increment on the active nodes (uniform, or linear with
    `rotations`) whose force and moment on B (about the origin) fit a given (6,) resultant
    in least squares."""
    def build():
        x = itf.points[act]
        centre = x.mean(axis=0)
        scale = np.sqrt((np.linalg.norm(x - centre, axis=1) ** 2).mean()) or 1.0
        phi = np.hstack([np.ones((len(x), 1)), (x - centre) / scale])
        R = itf.resultant[:, act]
        W = R @ phi
        W[3:] = (W[3:] - np.cross(centre, W[:3].T).T) / scale
        T = np.eye(6)  # t = T D: the moment about the centre, scaled
        T[3:, :3] = -np.array([[0, -centre[2], centre[1]], [centre[2], 0, -centre[0]],
                               [-centre[1], centre[0], 0]])
        T[3:] /= scale
        if not rotations:
            W, T, phi = W[:3, :1], T[:3], phi[:, :1]
        return phi @ np.linalg.pinv(W, rcond=1e-8) @ T
    return _cached(itf, "pressure", (act.tobytes(), rotations), build)


def _coarse_shifts(interfaces, residuals, active, omega, tree=None) -> dict:
    """Rigid motion (t, theta about the origin; u(x) = t + theta x x) of each anchored body
    predicted for the next iteration: the translation that fits (least squares) the relaxed
    residual of its anchor interface, plus its support's motion, so a column of bodies moves
    with its support in one iteration instead of one body per iteration. On the anchor tree
    the coarse problem of the bodies' translations is statically determinate: the motions
    follow from compatibility alone, summed from the held bodies up (and the forces from
    equilibrium alone, _coarse_forces). Bodies not anchored (held, or on open contacts only)
    do not move.

    Rotations are left out on purpose: a body also kinematic on other contacts (a pellet
    against its tube) passes a moment on to them as much as to its anchor, in proportions
    its stiffness decides and a tree sum cannot know; with rotations (and moments) in the
    coarse step the 10- and 20-pellet stacks diverged. Along the anchor normal frictionless
    side contacts carry nothing, so the translation part is exact there."""
    parent, order, alone = tree or _anchor_tree(interfaces, active)
    shift: dict = {}
    for body in reversed(order):  # supports first
        c = parent[body]
        itf, act = interfaces[c], active[c]
        rhs = omega[c] * residuals[c][act]
        support = shift.get(itf.b)
        if support is not None:
            # the support's motion as the anchor passes it on: only what moves the contact
            # along its normal (a tilt, the normal translation); a frictionless face passes
            # no sideways translation, so the lever arm of a tilt is not passed up the column
            rhs = rhs + _origin_rows(itf)[act] @ support
        shift[body] = _fit_motion(itf, act, ROTATIONS and body in alone) @ rhs
    return shift


def _coarse_forces(interfaces, p_old, p_new, active, tree=None) -> dict:
    """Pressure increments {interface: dp} (uniform over the active nodes) on the anchor
    interfaces that make every body held by an anchor pass on to its support the force its
    whole subtree of the anchor tree now carries: a balancing step. The coarse
    problem of the bodies' translations is statically determinate on the tree, so its forces
    follow from equilibrium alone, summed from the leaves towards the held bodies.

    Body a anchored on b through c balanced, in this iteration, its own loads and the forces of
    its children c' (the interfaces where a is the force side) as they were at the start of
    the iteration, R(p_old_c'); its reaction on c passes that on. The children have moved on,
    to R(p_new_c') plus their own corrections, and the difference D_a goes to b now instead of one iteration per body later: R_c(p_new_c + dp_c) = R_c(p_new_c) +
    D_a, dp_c uniform on the active nodes (the least-squares fit of the force; the fine
    iteration shapes the rest; moments are left out for the reason given in _coarse_shifts).
    At a converged iterate p_new = p_old everywhere, every D is zero: the fixed point is that
    of the plain iteration."""
    parent, order, alone = tree or _anchor_tree(interfaces, active)
    children: dict = {}
    for c, itf in enumerate(interfaces):
        children.setdefault(itf.b, []).append(c)
    dp: dict = {}
    for body in order:
        if body not in alone:
            continue  # its other contacts take their share of the change: not a tree sum
        D = np.zeros(6)
        for c in children.get(body, ()):
            R = interfaces[c].resultant
            D += R @ (p_new[c] - p_old[c])
            if c in dp:
                D += R @ dp[c]
        c = parent[body]
        d = np.zeros(len(active[c]))
        d[active[c]] = _fit_pressure(interfaces[c], active[c], ROTATIONS) @ D
        dp[c] = d
    return dp


class Anderson:
    """Anderson acceleration (type II, as in Walker and Ni 2011) of the fixed-point map the
    iteration is, x_k -> G(x_k), x the interfaces' gaps g, t_B and pressures p, p_B (scaled
    by the largest displacement and pressure): x_k+1 = G(x_k) - dG gamma, gamma the least-
    squares fit of the last `depth` residual differences dF to the residual G(x_k) - x_k.
    Within one active set the map is affine and this is GMRES on it: the smooth, slow modes
    of a Robin iteration (a tube bowing with the pellets it touches, both far softer than
    alpha) converge in a few dozen iterations instead of thousands. Restarted when an active
    or stick/slip set changes (the map changes)."""

    def __init__(self, depth: int, robin: list | None = None):
        self.depth = depth
        self.robin = robin or []
        self.reset()

    def reset(self):
        self.x = None  # the last iterate x_k (scaled)
        self.f = self.gx = None
        self.dF, self.dG = [], []

    def _parts(self, state):
        """(arrays, index, mask, scale kind) of the packed values: every interface's g and p
        on its active nodes, t_B and p_B on the active nodes of Robin interfaces (elsewhere
        they are unused or inactive: packing them made the least-squares fit four times
        longer for nothing; within one restart the active sets do not change)."""
        parts = []
        for c, act in enumerate(state.active):
            if not act.any():
                continue
            parts += [(state.g, c, act, 0), (state.p, c, act, 1)]
            if self.robin[c]:
                parts += [(state.tb, c, act, 0), (state.pb, c, act, 1)]
        return parts

    def _pack(self, state, us, ps):
        scale = (us, ps)
        parts = self._parts(state)
        if not parts:
            return np.zeros(0)
        return np.concatenate([arrays[c][act] / scale[k] for arrays, c, act, k in parts])

    def _unpack(self, state, x, us, ps):
        scale = (us, ps)
        i = 0
        for arrays, c, act, k in self._parts(state):
            n = int(act.sum())
            v = arrays[c].copy()
            v[act] = x[i:i + n] * scale[k]
            arrays[c] = v
            i += n

    def step(self, state, changed: bool, us: float, ps: float) -> None:
        if changed:
            self.reset()
            return
        # fixed scales for the whole history (the first of a restart)
        if self.x is None:
            self.us, self.ps = us, ps
            self.x = self._pack(state, self.us, self.ps)
            return
        gx = self._pack(state, self.us, self.ps)
        f = gx - self.x
        if self.f is not None:
            self.dF.append(f - self.f)
            self.dG.append(gx - self.gx)
            if len(self.dF) > self.depth:
                # restarted (as GMRES(m)): a sliding window stagnated on the 50-pellet
                # column (pressure mismatch 0.016 for 100 iterations)
                self.dF, self.dG = [], []
        self.f, self.gx = f, gx
        x = gx
        if self.dF:
            F = np.array(self.dF).T
            # QR with pivoting (gelsy): with numpy's SVD lstsq the 20-pellet stack stops 3.2e-3
            # from the monolithic answer instead of 1.9e-4 (docs/quasistatic.md, Known limits)
            gamma = scipy.linalg.lstsq(F, f, cond=1e-10, lapack_driver="gelsy",
                                       check_finite=False)[0]
            x = gx - np.array(self.dG).T @ gamma
        self.x = x
        self._unpack(state, x, self.us, self.ps)


def _predicted(itf: Interface, m) -> np.ndarray | float:
    """n . u at the interface's points of the rigid motion m (t, theta) of the coarse step."""
    if m is None:
        return 0.0
    return _origin_rows(itf) @ m


def initial_state(interfaces: list[Interface]) -> ContactState:
    act = []
    for itf in interfaces:
        scale = np.sqrt(itf.M_a.diagonal().mean()) if itf.M_a.shape[0] else 1.0
        act.append(itf.matched & ((itf.gap <= 1e-6 * scale) | itf.tied))
    return ContactState([itf.gap.copy() for itf in interfaces], act,
                        [np.zeros(len(itf.gap)) for itf in interfaces],
                        friction=friction.initial(interfaces, act),
                        tb=[itf.gap.copy() for itf in interfaces],
                        pb=[np.zeros(len(itf.gap)) for itf in interfaces])


def heat_phase(pool, route: dict, settings: Settings, dt: float | None, log: list) -> int:
    sends = pool.call("heat_begin", dt)
    if not route:
        pool.call("heat_solve", settings.picard_tolerance, settings.max_picard, per_body={})
        return 1
    old = None
    for it in range(1, settings.max_heat_iterations + 1):
        received: dict = {}
        for body, values in sends.items():
            for key, v in values.items():
                received.setdefault(route[key], {})[key] = v
        # one Picard step per body and iteration: the k(T) and the exchange iterations
        # converge together (a factorisation per body and iteration, not per Picard step)
        out = pool.call("heat_solve", settings.picard_tolerance, 1, per_body=received)
        sends = {b: v[0] for b, v in out.items()}
        picard = max((v[1] for v in out.values()), default=0.0)
        flat = np.concatenate([v for b in sorted(sends) for _, v in sorted(sends[b].items())])
        if old is not None:
            change = np.max(np.abs(flat - old)) / max(np.max(np.abs(flat)), 1e-30)
            log.append({"phase": "heat", "iteration": it, "change": max(change, picard)})
            if max(change, picard) < settings.heat_tolerance:
                return it
        old = flat
    raise NotConverged(f"heat: the interface temperatures did not settle in "
                       f"{settings.max_heat_iterations} iterations")


def mechanics_phase(pool, interfaces: list[Interface], settings: Settings, state: ContactState,
                    scale: float, log: list, step: int) -> dict:
    pool.call("mech_begin", scale)
    friction.begin_step(state.friction)
    n_b = len(interfaces)
    omega = settings.relaxation
    om = np.full(n_b, omega)  # per interface (one value today)
    r_old = None
    last_change = 0
    accel = Anderson(settings.anderson, [itf.robin > 0 for itf in interfaces])
    state.leaves = [np.zeros(len(itf.gap), np.int64) for itf in interfaces]  # per load step
    result = {"iterations": 0, "gap_residual": np.inf, "pressure_residual": np.inf}
    for it in range(1, settings.max_iterations + 1):
        inputs: dict = {}
        for c, itf in enumerate(interfaces):
            inputs.setdefault(itf.a, ({}, {}, {}, {}, {}))
            inputs.setdefault(itf.b, ({}, {}, {}, {}, {}))
            if itf.robin:
                # A: p = p_B + alpha (u_A . n - t_A); B: p = p_A + alpha (-u_B . n - t_B)
                inputs[itf.a][4][("a", c)] = (state.g[c], state.active[c], state.pb[c])
                inputs[itf.b][4][("b", c)] = (state.tb[c], state.active[c], state.p[c])
                continue
            inputs[itf.a][0][c] = state.g[c]
            inputs[itf.a][1][c] = state.active[c]
            inputs[itf.b][2][c] = state.p[c]
        friction.add_inputs(inputs, interfaces, state)
        out = pool.call("mech_solve", per_body=inputs)
        move = max((v["move"] for v in out.values()), default=0.0)
        u_scale = 1e-30
        p_scale = 1e-30
        gap_res = 0.0
        p_change = 0.0
        changed = False
        residuals = []
        new_active = []
        ua_all, ub_all, pa_all, pb_all = [], [], [], []
        # nodes that penetrate enter at once; nodes leave only once the iteration has settled
        # for the current active set (an outer loop): releasing at every iteration makes the
        # contact chatter
        for c, itf in enumerate(interfaces):
            if itf.robin:
                ua, pa = out[itf.a][("ra", c)]
                ub, pb = out[itf.b][("rb", c)]
            else:
                ua, pa = out[itf.a][("a", c)]
                ub, pb = out[itf.b][("b", c)], None
            pb_all.append(pb)
            ua_all.append(ua)
            ub_all.append(ub)
            pa_all.append(pa)
            u_scale = max(u_scale, np.max(np.abs(ua), initial=0), np.max(np.abs(ub), initial=0))
            p_scale = max(p_scale, np.max(np.abs(pa), initial=0))
        # (on a Robin interface the mismatches are the gap between the new iterates and the
        # difference of the two sides' pressures)
        pre_gap = max((np.max(np.abs(np.where(
            state.active[c], ub_all[c] + itf.gap - (ua_all[c] if itf.robin else state.g[c]),
            0.0)), initial=0) / u_scale for c, itf in enumerate(interfaces)), default=0.0)
        # (a Robin interface's pressure mismatch is alpha times its gap mismatch, which
        # pre_gap measures: with alpha 1e14 Pa/m a 1e-5 relative gap is a 1e-2 relative
        # pressure on the 50-pellet stack, and waiting for it delayed every release by the
        # MAX_INNER iterations)
        pre_p = max((np.max(np.abs(pa_all[c] - state.p[c]), initial=0) / p_scale
                     for c in range(n_b) if not interfaces[c].robin), default=0.0)
        settle = it == 1 or (pre_gap <= SETTLE * max(settings.gap_tolerance, 1e-3) and
                             pre_p <= SETTLE * max(settings.pressure_tolerance, 1e-3)) or \
            it - last_change >= MAX_INNER
        worst = [(0.0, -1), (0.0, -1)]  # (mismatch, interface) of the gap and the pressure
        for c, itf in enumerate(interfaces):
            ua, ub, pa = ua_all[c], ub_all[c], pa_all[c]
            g0, p0 = gap_res, p_change
            act = state.active[c]
            target = ub + itf.gap
            if itf.robin:
                pb = pb_all[c]
                r = np.where(act, target - ua, 0.0)  # the gap itself
                p_change = max(p_change, np.max(np.abs(pa - pb), initial=0) / p_scale,
                               np.max(np.abs(pa - state.p[c]), initial=0) / p_scale)
                p_act = 0.5 * (pa + pb)
            else:
                r = np.where(act, target - state.g[c], 0.0)
                p_change = max(p_change, np.max(np.abs(pa - state.p[c]), initial=0) / p_scale)
                p_act = pa
            residuals.append(r)
            gap_res = max(gap_res, np.max(np.abs(r), initial=0) / u_scale)
            if gap_res > g0:
                worst[0] = (gap_res, c)
            if p_change > p0:
                worst[1] = (p_change, c)
            if itf.robin and not settle:
                # a Robin interface's set changes only on settled iterates (an outer loop):
                # a penetration is no instability there (the spring pushes back), and the
                # early iterates of the pellet stack threw pellets into their tube and out
                # again, resetting the acceleration at each change
                na = act
            else:
                pen_tol = ACTIVATE * settings.gap_tolerance * u_scale
                if itf.robin:
                    # a node that left enters again only deeper: the pellets of a long
                    # column touch their tube on a few nodes of nearly equal depth; entered at
                    # the threshold they were thrown off and came back, some every few
                    # iterations (350 bodies: no convergence in 900; with this 554)
                    pen_tol = pen_tol * CHATTER ** state.leaves[c]
                na = update_active(itf, act, p_act, ua - target, pen_tol, p_scale,
                                   release=settle)
                if itf.robin:
                    state.leaves[c] += act & ~na
            changed |= bool((na != act).any())
            new_active.append(na)
        # (stick and slip are decided on settled iterates, never on the first one)
        fm, pending = friction.measure(interfaces, state, out, pa_all, new_active,
                                       settle and it > 1, u_scale, p_scale)
        gap_res, p_change = max(gap_res, fm.gap), max(p_change, fm.change)
        changed |= fm.changed
        r = np.concatenate(residuals + fm.residuals) if residuals else np.zeros(0)
        # (Python's max drops NaN, so the residual vector is checked too)
        if not all(np.isfinite(v) for v in (gap_res, p_change, u_scale, p_scale)) or \
                not np.isfinite(r).all():
            raise NotConverged(f"Schwarz iteration: diverged at iteration {it} (the "
                               f"mismatches are not finite)")
        if settings.aitken and r_old is not None and not changed and len(r) == len(r_old) \
                and np.any(r_old):
            dr = r - r_old
            den = float(dr @ dr)
            if den > 0:
                omega = float(np.clip(-omega * float(r_old @ dr) / den, 0.05, 1.5))
        elif changed:
            omega = settings.relaxation
        om[:] = omega
        log.append({"phase": "mechanics", "step": step, "iteration": it,
                    "gap_residual": gap_res, "pressure_residual": p_change,
                    "motion_residual": move / u_scale,
                    "relaxation": omega, "active": int(sum(a.sum() for a in new_active)),
                    "active_changed": changed, "worst_gap_interface": worst[0][1],
                    "worst_pressure_interface": worst[1][1]})
        p_new = [np.where(new_active[c], pa_all[c], 0.0) for c in range(n_b)]
        shift, dp = {}, {}
        if settings.coarse:
            tree = _anchor_tree(interfaces, new_active)
            shift = _coarse_shifts(interfaces, residuals, new_active, om, tree)
            dp = _coarse_forces(interfaces, state.p, p_new, new_active, tree)
        for c in range(n_b):
            itf = interfaces[c]
            pred = _predicted(itf, shift.get(itf.b))
            if itf.robin:
                # no relaxation: each side's next target is the other's new position (Lions'
                # Robin-Robin iteration converges without it), its pressure the other's
                state.g[c] = ub_all[c] + itf.gap + pred
                state.tb[c] = itf.gap - ua_all[c] - _predicted(itf, shift.get(itf.a))
                state.p[c] = p_new[c]
                state.pb[c] = np.where(new_active[c], pb_all[c], 0.0)
                continue
            state.g[c] = np.where(new_active[c], state.g[c] + om[c] * residuals[c] + pred,
                                  ub_all[c] + interfaces[c].gap)
            state.p[c] = p_new[c] + dp.get(c, 0.0)
        friction.advance(state, pending, om)
        if settings.anderson:
            accel.step(state, changed or fm.changed, u_scale, p_scale)
        if changed:
            last_change = it
        state.active = new_active
        state.ua, state.ub = ua_all, ub_all
        r_old = None if changed else r
        result = {"iterations": it, "gap_residual": gap_res, "pressure_residual": p_change,
                  "motion_residual": move / u_scale}
        # (and the bodies have stopped: compatible faces and steady pressures while a body
        # still moves mean its weak springs carry force, which they do not at the fixed point)
        if not n_b or (it >= 2 and not changed and gap_res <= settings.gap_tolerance
                       and p_change <= settings.pressure_tolerance
                       and move <= settings.gap_tolerance * u_scale):
            result["max_penetration"] = max_penetration(interfaces, state)
            return result
    raise NotConverged(f"Schwarz iteration: no convergence in {settings.max_iterations} "
                       f"iterations (gap mismatch {gap_res:.3g}, pressure mismatch "
                       f"{p_change:.3g}; tolerances {settings.gap_tolerance:g}, "
                       f"{settings.pressure_tolerance:g})")
