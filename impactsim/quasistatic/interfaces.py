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


def setup(problem: Problem):
    """(spaces, interfaces, specs, heat routing {key: receiving body}, seconds)."""
    t0 = time.perf_counter()
    bodies = problem.bodies
    spaces = [Space(b.mesh(), b.order) for b in bodies]
    pairs = find_pairs(problem, spaces)
    dist = _support_distance(len(bodies), [b.fixed for b in bodies], pairs)
    stiffness = [b.material.youngs_modulus * np.cbrt(np.prod(np.ptp(b.points, axis=1)))
                 for b in bodies]
    anchor = {}
    for k, (i, j, *_, closed) in enumerate(pairs):
        if not closed:
            continue
        for x, y in ((i, j), (j, i)):
            if not bodies[x].fixed and dist[y] < dist[x]:
                best = anchor.get(x)
                if best is None or stiffness[y] > stiffness[best[1]]:
                    anchor[x] = (k, y)
    anchored = {k: x for x, (k, _) in anchor.items()}
    interfaces = []
    for k, (i, j, fi, fj, rule, closed) in enumerate(pairs):
        if k in anchored:
            kin = anchored[k]
        else:
            kin = i if (stiffness[i], -i) < (stiffness[j], -j) else j
        if kin == i:
            a, b, fa, fb = i, j, fi, fj
        else:
            a, b, fa, fb = j, i, fj, fi
        interfaces.append(coupling.build(a, b, spaces[a], spaces[b], fa, fb, rule.friction,
                                         rule.conductance, rule.tied))
        interfaces[-1].anchor = k in anchored
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
        if T is None:
            specs[itf.a].kin.append((c, itf.C_a, itf.M_a))
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
