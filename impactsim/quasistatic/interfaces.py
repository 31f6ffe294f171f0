"""From a ``Problem`` to the interfaces and the per-body specs the workers build.

Contact pairs are detected (bodies whose boxes come within the gap tolerance, then facets with
opposed normals closer than it) or taken from the listed pairs; each gets the properties of the
first ``ContactRule`` its two names match.

Roles (kinematic side A, force side B). Dirichlet-Neumann iterations converge when the
Dirichlet (kinematic) side is the more compliant one, and a body that is not held by its own
conditions must be kinematic somewhere, or forces alone act on it and it drifts. So:
1. each body not held gets an anchor: the initially closed interface towards a neighbour nearer
   (in closed-contact hops) to a held body, the stiffest such neighbour; it is kinematic there;
2. on every other interface the more compliant body (smaller E times its size) is kinematic.
"""

from __future__ import annotations

import fnmatch
import time
from collections import deque

import numpy as np
import scipy.sparse as sp

from impactsim.quasistatic import coupling, friction
from impactsim.quasistatic.body import BodySpec
from impactsim.quasistatic.elastic import rigid_modes
from impactsim.quasistatic.matching import boxes_overlap, detect, locate
from impactsim.quasistatic.model import ContactRule, Problem
from impactsim.quasistatic.space import Space


class SetupError(Exception):
    pass


def rule_for(rules: list[ContactRule], a: str, b: str) -> ContactRule | None:
    for r in rules:
        if (fnmatch.fnmatchcase(a, r.first) and fnmatch.fnmatchcase(b, r.second)) or \
                (fnmatch.fnmatchcase(b, r.first) and fnmatch.fnmatchcase(a, r.second)):
            return r
    return None


def find_pairs(problem: Problem, spaces: list[Space]) -> list[tuple[int, int, np.ndarray,
                                                                      np.ndarray, ContactRule]]:
    bodies = problem.bodies
    tol = problem.settings.detect_tolerance
    names = [b.name for b in bodies]
    if problem.pairs is not None and not problem.settings.detect:
        index = {n: i for i, n in enumerate(names)}
        candidates = sorted({tuple(sorted((index[a], index[b]))) for a, b in problem.pairs})
    else:
        lo = np.array([b.points.min(axis=1) for b in bodies])
        hi = np.array([b.points.max(axis=1) for b in bodies])
        candidates = boxes_overlap(lo, hi, max(tol, max((r.gap_tolerance or 0)
                                                        for r in problem.rules) if problem.rules
                                                   else tol))
    geo = {}

    def surface(i):
        if i not in geo:
            bf = spaces[i].mesh.boundary_facets()
            x, n = spaces[i].facet_geometry(bf)
            geo[i] = (bf, x, n)
        return geo[i]

    out = []
    for i, j in candidates:
        rule = rule_for(problem.rules, names[i], names[j])
        if rule is None:
            if problem.rules:
                continue
            rule = ContactRule()
        t = rule.gap_tolerance if rule.gap_tolerance is not None else tol
        bi, xi, ni = surface(i)
        bj, xj, nj = surface(j)
        fi, fj = detect(xi, ni, xj, nj, t)
        if len(fi) and len(fj):
            verts = np.unique(spaces[i].mesh.facets[:, bi[fi]])
            _, _, d = locate(spaces[i].mesh.p[:, verts].T, xj[fj])
            size = np.ptp(xi.reshape(-1, 3), axis=0).max()
            closed = bool(d.min() <= 1e-9 * size)
            out.append((i, j, bi[fi], bj[fj], rule, closed))
        elif problem.pairs is not None and not problem.settings.detect:
            raise SetupError(f"listed contact pair '{names[i]}' / '{names[j]}': the surfaces "
                             f"are nowhere closer than the gap tolerance {t:g} m")
    return out


def robin_mass(itf) -> sp.csr_matrix:
    """A's surface mass lumped (row sums) on a Robin interface: the springs alpha m_i of a
    node-to-surface penalty; the consistent mass made the nodal pressures alternate in sign
    from node to node (+-1 GPa on the 50-pellet stack, tet4)."""
    return sp.diags(np.asarray(itf.M_a.sum(axis=1)).ravel()).tocsr()


def names_of(bodies, i: int) -> str:
    return bodies[i].name


def _support_distance(n: int, fixed: list[bool], pairs) -> list[int]:
    adj = [[] for _ in range(n)]
    for i, j, *_, closed in pairs:
        if closed:
            adj[i].append(j)
            adj[j].append(i)
    dist = [-1] * n
    q = deque(i for i in range(n) if fixed[i])
    for i in q:
        dist[i] = 0
    while q:
        i = q.popleft()
        for j in adj[i]:
            if dist[j] < 0:
                dist[j] = dist[i] + 1
                q.append(j)
    return [d if d >= 0 else 10**9 for d in dist]


def _solver(settings, ndof: int, held: bool) -> str:
    """direct or amg. A body held only by its contacts is always factorised: its stiffness
    plus the 1e-6 springs has a condition number of 1e6 and more, and its Schur complement
    C K^-1 C^T is dominated by the rigid modes; iterative solves to 1e-10 lose its elastic
    part (measured: an indefinite Schur complement on the upper block of blocks-pressed)."""
    if not held:
        return "direct"
    if settings.solver != "auto":
        return settings.solver
    return "amg" if ndof > settings.direct_limit else "direct"


def _held(body, space: Space, closed_facets: list) -> bool:
    """Whether the body's displacement conditions hold it against its closed contacts: every
    rigid-body mode they leave free (all six for a body without any) moves none of its
    closed contact facets along their normal. A pellet held in z on its end plug is held (its
    free modes, sideways and about its axis, slide along its flat ends); a quarter sphere
    held on its symmetry planes but free along the axis it is pressed along is not, and must
    be kinematic on its contact (a force side would get forces alone and drift)."""
    x = space.mesh.p
    centre = x.mean(axis=1, keepdims=True)
    size = float(np.ptp(x)) or 1.0
    rows = []
    for c in body.conditions:
        if c.kind != "displacement" or c.facets is None or not len(c.facets):
            continue
        v = np.unique(space.mesh.facets[:, c.facets])
        R = rigid_modes(x[:, v] - centre, centred=False).reshape(len(v), 3, 6)
        for k, val in enumerate(c.vector):
            if val is not None:
                rows.append(R[:, k] / np.array([1, 1, 1, size, size, size]))
    if not rows:
        return False
    A = np.vstack(rows)
    _, sv, vt = np.linalg.svd(A, full_matrices=True)
    rank = int((sv > 1e-9 * sv.max()).sum()) if sv.size else 0
    free = vt[rank:]  # (k, 6) in scaled coordinates
    if not len(free):
        return True
    for facets in closed_facets:
        xf, nf = space.facet_geometry(np.asarray(facets))
        xc = xf.mean(axis=1) - centre.T
        modes = free * np.array([1, 1, 1, 1 / size, 1 / size, 1 / size])
        t, th = modes[:, :3], modes[:, 3:]
        # n . (t + theta x r) for every free mode and facet
        normal = nf @ t.T + np.einsum("fc,kfc->fk", nf, np.cross(th[:, None, :], xc[None]))
        if np.abs(normal).max() > 1e-3:
            return False
    return True


def setup(problem: Problem):
    """(spaces, interfaces, specs, heat routing {key: receiving body}, seconds)."""
    t0 = time.perf_counter()
    bodies = problem.bodies
    spaces = [Space(b.mesh(), b.order) for b in bodies]
    pairs = find_pairs(problem, spaces)
    held = [_held(b, spaces[i], [(fi if x == i else fj) for x, y, fi, fj, _, closed in pairs
                                 if closed and i in (x, y)])
            for i, b in enumerate(bodies)]
    dist = _support_distance(len(bodies), held, pairs)
    stiffness = [b.material.youngs_modulus * np.cbrt(np.prod(np.ptp(b.points, axis=1)))
                 for b in bodies]
    anchor = {}
    for k, (i, j, *_, closed) in enumerate(pairs):
        if not closed:
            continue
        for x, y in ((i, j), (j, i)):
            if not held[x] and dist[y] < dist[x]:
                best = anchor.get(x)
                if best is None or stiffness[y] > stiffness[best[1]]:
                    anchor[x] = (k, y)
    anchored = {k: x for x, (k, _) in anchor.items()}
    interfaces = []
    for k, (i, j, fi, fj, rule, closed) in enumerate(pairs):
        if k in anchored:
            kin = anchored[k]
        else:
            # a body kinematic on its anchor is clamped there already: kinematic here too it
            # would be held at two places, the stiff side, and a Dirichlet-Neumann iteration
            # with the stiff side kinematic diverges (a pellet pressed into its thin tube: two
            # nodes at 0.9 GPa bent the tube by 2 mm in one iteration). So it is the force
            # side, unless the other body is anchored too: then the more compliant one.
            if (i in anchor) != (j in anchor):
                kin = j if i in anchor else i
            else:
                kin = i if (stiffness[i], -i) < (stiffness[j], -j) else j
        if kin == i:
            a, b, fa, fb = i, j, fi, fj
        else:
            a, b, fa, fb = j, i, fj, fi
        interfaces.append(coupling.build(a, b, spaces[a], spaces[b], fa, fb, rule.friction,
                                         rule.conductance, rule.tied))
        interfaces[-1].anchor = k in anchored
        if rule.robin > 0:
            if rule.friction:
                raise SetupError(f"contact pair '{names_of(bodies, i)}' / "
                                 f"'{names_of(bodies, j)}': robin and friction cannot be "
                                 f"combined (Robin conditions are normal only)")
            # an anchor stays kinematic: the coarse step passes motions along anchors
            interfaces[-1].robin = 0.0 if k in anchored else rule.robin
        friction.attach(interfaces[-1], spaces[a], spaces[b])
    thermal_bodies = any(c.kind in ("temperature", "flux", "exchange", "source")
                         for b in bodies for c in b.conditions)
    thermal = thermal_bodies or any(itf.conductance > 0 for itf in interfaces)
    s = problem.settings
    specs = [BodySpec(i, b, s.regularization, thermal=thermal,
                      solver=_solver(s, 3 * spaces[i].n, b.fixed))
             for i, b in enumerate(bodies)]
    route = {}
    for c, itf in enumerate(interfaces):
        T = itf.tangential
        if itf.robin > 0:  # Robin on both sides: rows R and force columns F (body.py)
            specs[itf.a].robin.append((c, "a", itf.C_a, itf.C_a.T.tocsr(), robin_mass(itf),
                                       itf.robin))
            specs[itf.b].robin.append((c, "b", -itf.I_b, -itf.G_b, None, itf.robin))
        elif T is None:
            specs[itf.a].kin.append((c, itf.C_a, itf.M_a))
            if itf.tied:
                specs[itf.a].tied.append((c, np.nonzero(itf.matched)[0]))
            specs[itf.b].force.append((c, itf.I_b, itf.G_b))
        else:  # friction: tangential rows and tractions beside the normal ones
            specs[itf.a].kin.append((c, sp.vstack([itf.C_a, T.C_t]).tocsr(), itf.M_a))
            specs[itf.b].force.append((c, sp.vstack([itf.I_b, T.I_t]).tocsr(),
                                       sp.hstack([itf.G_b, T.G_t]).tocsr()))
            specs[itf.a].friction.add(c)
            specs[itf.b].friction.add(c)
        if itf.heat_a is not None:
            H, L, P = itf.heat_a
            specs[itf.a].heat.append(((c, "a"), H, L))
            specs[itf.b].heat_send.append(((c, "a"), P))
            route[(c, "a")] = itf.a
            H, L, P = itf.heat_b
            specs[itf.b].heat.append(((c, "b"), H, L))
            specs[itf.a].heat_send.append(((c, "b"), P))
            route[(c, "b")] = itf.b
    return spaces, interfaces, specs, route, time.perf_counter() - t0
