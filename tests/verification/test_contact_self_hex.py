"""Self-contact of hex bodies (contact/hexes.py, contact/passes.py): two fragments of one hex
body (one mesh, two pieces, the second turned 30 degrees so that edges cross edges) driven into
each other stay apart, and the broad phase never pairs a node or an edge with a face or crease of
its own quad.

The penetration measure (contact/diagnostics.py) does not measure a body against itself; the
test measures the two fragments against each other by labelling them as two bodies for the
meter (the same HexSurface and ProxyTets the run uses)."""

import dataclasses

import numpy as np
import pytest

from impactsim.case.schema import Contact
from impactsim.contact.diagnostics import PenetrationMeter
from impactsim.contact.hexes import HexSurface, ProxyTets
from impactsim.contact.passes import make_contact_passes
from impactsim.mesh.hexes import box_hexes, fix_hex_orientation
from impactsim.solver.build import build_model
from impactsim.solver.loop import Simulation
from impactsim.solver.pipeline import build_passes
from tests.builders import box_case, material


def _two_fragments(gap=1e-5, h=1e-3, turn=np.radians(30.0)):
    lower, lh = box_hexes((6e-3, 6e-3, 2e-3), h)
    upper, uh = box_hexes((3e-3, 3e-3, 2e-3), h)
    c, s = np.cos(turn), np.sin(turn)
    upper = upper @ np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]]).T
    lower[:, 2] -= 1e-3
    upper[:, 2] += 1e-3 + gap
    pts = np.vstack([lower, upper])
    hexes = np.vstack([lh, uh + len(lower)])
    hexes, _ = fix_hex_orientation(pts, hexes)
    return pts, hexes.astype(np.int32), len(lower)


def _model(passes=("node-face", "edge-edge")):
    pts, hexes, n_lower = _two_fragments()
    mat = material(name="al", density=2700.0, shear_modulus=26e9, bulk_modulus=70e9)
    case = box_case(mat, size=(6e-3, 6e-3, 4e-3), h=1e-3, end=3e-6)
    case.bodies[0].element = "hex8"
    case.bodies[0].hourglass = "stiffness"
    case.bodies[0].hourglass_coefficient = 0.05
    case.contact = Contact(passes=list(passes), self_contact=True)
    model = build_model(case, [(pts, hexes)])
    return case, model, n_lower


def _fragment_penetration(model, meter, n_lower):
    """max_penetration between the two fragments, labelled as two bodies for the meter."""
    label = (np.arange(model.n_node) >= n_lower).astype(np.int32)
    blk = model.blocks[0]
    fake = dataclasses.replace(
        model, node_body=label, body_names=["lower", "upper"],
        blocks=[dataclasses.replace(blk, elem_body=label[blk.conn[:, 0]])])
    surface = HexSurface(fake)
    x, conn, elem_body, status = ProxyTets(fake).update(fake)
    return meter.measure(x, conn, elem_body, status, surface)["max_penetration"]


def test_two_fragments_of_one_hex_body_stay_apart():
    case, model, n_lower = _model()
    upper = np.arange(model.n_node) >= n_lower
    model.v[upper, 2] = -400.0
    passes = build_passes(case, model)
    assert any(p.name == "contact.edge-edge" for p in passes)
    sim = Simulation(model, passes, cfl=0.5)
    meter = PenetrationMeter()
    p0 = model.mass @ model.v
    worst = 0.0
    touched = 0
    while model.time < 2.5e-6:
        sim.step()
        worst = max(worst, _fragment_penetration(model, meter, n_lower))
        touched += passes[0].ctx.last["contact.node-face"]["pairs"] > 0
    assert touched > 10  # the fragments met
    assert worst < 1e-6
    # the upper fragment was stopped (it would be 1.5 mm into the lower one without contact)
    vz_upper = (model.mass[upper] @ model.v[upper, 2]) / model.mass[upper].sum()
    assert vz_upper > -300.0
    np.testing.assert_allclose(model.mass @ model.v, p0, atol=1e-9 * abs(p0[2]))


def test_self_contact_never_pairs_an_entity_with_its_own_quad():
    """With self-contact, the candidates of node-face exclude every node of the face's quad
    (the other triangle's too), those of edge-edge every edge touching a crease's quad; pairs of
    the two fragments remain."""
    case, model, n_lower = _model()
    # warp the surface a little so that quads are not plane
    rng = np.random.default_rng(0)
    model.x += 1e-5 * rng.standard_normal(model.x.shape)
    passes = make_contact_passes(case, model)
    ctx = passes[0].ctx
    s = ctx.surface
    h = ctx.prepare(model)
    nf = passes[0]._candidates(model, 1e-9, h)
    quad_nodes = s.face_key[nf[:, 1]]
    node = s.nodes[nf[:, 0]]
    assert not np.any(quad_nodes == node[:, None])
    ee = passes[1]._candidates(model, 1e-9, h)
    ka, kb = s.edge_key[ee[:, 0]], s.edge_key[ee[:, 1]]
    assert not np.any(ka[:, :, None] == kb[:, None, :])
    creases = s.edge_key[:, 2:] != s.edges  # a crease's key is its quad
    assert creases.any(axis=1).sum() == len(s.faces) // 2
    # both kinds of pairs exist across the gap between the fragments
    lower = np.arange(model.n_node) < n_lower
    assert np.any(lower[node] != lower[s.faces[nf[:, 1], 0]])
    assert np.any(lower[s.edges[ee[:, 0], 0]] != lower[s.edges[ee[:, 1], 0]])
