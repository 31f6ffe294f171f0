"""The contact passes' candidate lists kept with a skin through surface changes (contact/skin.py):
while elements erode at the contact every step, the kept list follows the surface without a
build, and the candidate pairs stay those of the broad phase run afresh, in the same order."""

import numpy as np
import pytest
from test_contact_passes import case_with, make_model, rot, step

from impactsim.contact import make_contact_passes
from impactsim.mesh.structured import structured_box


def _blocks():
    a = structured_box((0.02, 0.02, 0.01), 0.004)
    b = structured_box((0.01, 0.01, 0.01), 0.003)
    b = (b[0] @ rot(2, 17).T + [0.001, 0.002, 0.0103], b[1])
    return a, b


def _twins(m, self_contact):
    """The passes with a kept list, and the same passes running the broad phase afresh."""
    kept = make_contact_passes(case_with(self_contact=self_contact), m)
    fresh = make_contact_passes(case_with(self_contact=self_contact), m)
    for p in fresh:
        p.skin.skin_rel = 0.0
    return kept, fresh


def _candidates(passes, m, dt):
    out = []
    for p in passes:
        h = p.ctx.prepare(m)
        out.append(p._candidates(m, dt, h).copy())
    return out


def _erode_near(m, surface, body, point, k):
    """Erode the k alive elements of ``body`` with a face on the surface whose centroids lie
    nearest ``point`` (the contact zone)."""
    elems = np.unique(surface.face_elem[surface.face_body == body])
    elems = elems[m.status[elems] != 3]
    c = m.x[m.conn[elems]].mean(axis=1)
    order = np.argsort(np.linalg.norm(c - point, axis=1), kind="stable")
    m.status[elems[order[:k]]] = 3


def _run(self_contact, steps=30, dt=2e-7, hook=None):
    """Both blocks eroding at the contact at every step from step 4 on; per step, the
    candidates of the kept list and of the fresh broad phase (both passes), compared."""
    a, b = _blocks()
    m = make_model([a, b], [(0, 0, 0), (30.0, -20.0, -300.0)])
    kept, fresh = _twins(m, self_contact)
    joined = 0
    pairs = 0
    for k in range(steps):
        s = kept[0].ctx.surface
        if k >= 4:
            before = set(s.nodes.tolist())
            zc = 0.5 * (m.x[m.node_body == 0, 2].max() + m.x[m.node_body == 1, 2].min())
            centre = np.array([0.001, 0.002, zc])
            _erode_near(m, s, 0, centre, 2)
            if k % 3 == 0:
                _erode_near(m, s, 1, centre, 1)
            kept[0].ctx.prepare(m)
            joined += len(set(kept[0].ctx.surface.nodes.tolist()) - before)
        if hook is not None:
            hook(k, m, kept)
        got = _candidates(kept, m, dt)
        want = _candidates(fresh, m, dt)
        for p, g, w in zip(kept, got, want):
            assert np.array_equal(g, w), (k, p.name, g.shape, w.shape)
            pairs += g.shape[0]
        step(m, kept, dt)
    return kept, joined, pairs


@pytest.mark.parametrize("self_contact", [False, True])
def test_kept_list_follows_erosion_with_the_pairs_of_a_fresh_broad_phase(self_contact):
    """Elements erode at the contact at every step (both bodies): the kept lists follow the
    changes without a build at each, nodes from inside the bodies join the surface, and the
    candidate pairs of both passes equal the fresh broad phase's at every step."""
    kept, joined, pairs = _run(self_contact)
    assert pairs > 0
    assert joined > 0  # interior nodes joined the surface (their build positions were inside)
    for p in kept:
        sk = p.skin
        assert sk.follows >= 10, (p.name, sk.follows, sk.builds)
        assert 2 <= sk.builds < 20, (p.name, sk.builds)


def test_kept_and_fresh_runs_give_bit_identical_velocities_under_erosion():
    """The same scene stepped with kept lists and with the broad phase afresh (no candidate
    comparison in between): the same velocities, bit for bit."""
    runs = []
    for skin in (0.2, 0.0):
        a, b = _blocks()
        m = make_model([a, b], [(0, 0, 0), (30.0, -20.0, -300.0)])
        passes = make_contact_passes(case_with(), m)
        for p in passes:
            p.skin.skin_rel = skin
        for k in range(30):
            if k >= 4:
                s = passes[0].ctx.surface
                zc = 0.5 * (m.x[m.node_body == 0, 2].max() + m.x[m.node_body == 1, 2].min())
                _erode_near(m, s, 0, np.array([0.001, 0.002, zc]), 2)
            step(m, passes, 2e-7)
        runs.append((m.v.copy(), [p.skin.follows for p in passes]))
    assert np.array_equal(runs[0][0], runs[1][0])
    assert min(runs[0][1]) > 0


def test_a_new_entity_outside_the_builds_selection_rebuilds_the_list():
    """An interior node of the lower block moved (before a build) out of the block's box,
    beside the upper block, then exposed by erosion: it lies outside what the build selected
    against (its body's box), so the list is built afresh rather than followed, and the pairs
    stay the fresh broad phase's; the same when the build's occupancy marks say a left-out row
    of the other body shares the new entities' cells."""
    state = {}

    def hook(k, m, kept):
        s = kept[0].ctx.surface
        if k == 2:  # an interior node of the lower block, next to the upper block
            inner = np.setdiff1d(np.flatnonzero(m.node_body == 0), s.nodes)
            top = m.x[inner, 2].max()
            cand = inner[m.x[inner, 2] == top]
            i = cand[np.argmin(np.linalg.norm(m.x[cand, :2] - [0.001, 0.002], axis=1))]
            m.x[i, 2] = m.x[m.node_body == 1, 2].min() + 0.0005
            state["node"] = i
            for p in kept:  # build at these positions
                p.skin.pairs = None
        if k == 3:
            state["uncovered"] = [p.skin.uncovered for p in kept]
            elems = np.flatnonzero(np.any(m.conn == state["node"], axis=1))
            m.status[elems[0]] = 3

    kept, _, pairs = _run(False, steps=6, hook=hook)
    assert pairs > 0
    assert all(p.skin.uncovered > u for p, u in zip(kept, state["uncovered"]))

    def mark_all(k, m, kept):  # every cell holds a left-out row of every body
        if k == 5:
            for p in kept:
                state[p.name] = p.skin.uncovered
        if k >= 5:
            for p in kept:
                r = p.skin._record
                for d in (r.dropped if r is not None else []):
                    if d is not None:
                        d.bits[:] = -1
                        d.gen[:] = d.g

    kept, _, pairs = _run(False, steps=9, hook=mark_all)
    assert pairs > 0
    assert all(p.skin.uncovered > state[p.name] for p in kept)


def test_hex_surface_identities_increase_through_erosion():
    """The kept list follows a surface by the identities of its entities, increasing in the
    compact arrays' order (``ContactContext.identities``): also for a hex surface, whose two
    triangles of a quad share element and local face, before and after hexes erode; an
    entity that stays keeps its identity and its nodes."""
    from test_contact_hexes import _model

    from impactsim.contact.hexes import HexSurface
    from impactsim.contact.skin import match_rows
    from impactsim.mesh.hexes import box_hexes, fix_hex_orientation

    pts, hexes = box_hexes((0.4, 0.3, 0.3), 0.1)
    hexes, _ = fix_hex_orientation(pts, hexes)
    m = _model((pts, hexes))
    ctx = make_contact_passes(case_with(self_contact=True), m)[0].ctx
    assert isinstance(ctx.surface, HexSurface)
    s = ctx.surface
    before = ctx.identities()
    rows = (s.faces, s.edges, s.nodes.reshape(-1, 1))
    assert all(i is not None for i in before)
    status = m.blocks[0].status
    status[[0, 5, 17]] = 3  # a corner hex, and hexes on faces of the box
    ctx.prepare(m)
    after = ctx.identities()
    assert s.version > 0 and all(i is not None for i in after)
    new_rows = (s.faces, s.edges, s.nodes.reshape(-1, 1))
    joined = 0
    for old, new, r0, r1 in zip(before, after, rows, new_rows):
        remap = np.empty(old.shape[0], np.int64)
        fresh = np.empty(new.shape[0], np.int64)
        joined += match_rows(old, new, remap, fresh)
        kept = remap >= 0
        assert np.all(np.diff(remap[kept]) > 0)
        assert np.array_equal(r0[kept], r1[remap[kept]])
        assert kept.sum() < old.shape[0]  # some left
    assert joined > 0  # the hexes beneath joined the surface
