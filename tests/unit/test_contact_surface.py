"""Contact surfaces: per-body boundary faces/edges/nodes, and incremental erosion == rebuild."""

import numpy as np
import pytest

from impactsim.contact.surface import ERODED, Surface
from impactsim.mesh.structured import structured_box
from impactsim.mesh.topology import boundary_edges, boundary_faces, boundary_nodes


def two_bodies():
    x1, t1 = structured_box((1.0, 1.0, 1.0), 0.5)
    x2, t2 = structured_box((1.0, 2.0, 1.0), 0.5)
    x2 = x2 + [0.0, 0.0, 1.5]
    conn = np.vstack([t1, t2 + len(x1)]).astype(np.int32)
    elem_body = np.repeat([0, 1], [len(t1), len(t2)]).astype(np.int32)
    node_body = np.repeat([0, 1], [len(x1), len(x2)]).astype(np.int32)
    return np.vstack([x1, x2]), conn, elem_body, node_body


def same_surface(a: Surface, b: Surface):
    for name in ("faces", "face_elem", "face_local", "face_body", "face_edges", "edges",
                 "edge_body", "edge_mesh", "nodes", "node_body"):
        np.testing.assert_array_equal(getattr(a, name), getattr(b, name), err_msg=name)
    np.testing.assert_array_equal(a.edge_count, b.edge_count)
    np.testing.assert_array_equal(a.node_count, b.node_count)


def test_surface_of_two_bodies():
    x, conn, eb, nb = two_bodies()
    s = Surface(conn, eb, node_body=nb)
    faces, elem, local = boundary_faces(conn)
    np.testing.assert_array_equal(s.faces, faces)
    np.testing.assert_array_equal(s.face_elem, elem)
    np.testing.assert_array_equal(s.face_body, eb[elem])
    np.testing.assert_array_equal(s.edges, boundary_edges(faces))
    np.testing.assert_array_equal(s.nodes, boundary_nodes(faces))
    np.testing.assert_array_equal(s.node_body, nb[s.nodes])
    np.testing.assert_array_equal(s.edge_body, nb[s.edges[:, 0]])
    # face_edges point at the face's own edges; a closed surface uses each edge twice
    fe = np.sort(s.edges[s.face_edges].reshape(len(faces), -1), axis=1)
    pairs = np.sort(faces[:, [0, 1, 1, 2, 2, 0]], axis=1)
    np.testing.assert_array_equal(fe, pairs)
    assert np.all(s.edge_count[s.edge_mesh] == 2)
    # node_body derived from the elements when not given
    same_surface(s, Surface(conn, eb))
    assert s.mean_edge_length(x) > 0.4


def test_incremental_erosion_equals_rebuild():
    x, conn, eb, nb = two_bodies()
    rng = np.random.default_rng(1)
    s = Surface(conn, eb, node_body=nb)
    status = np.zeros(len(conn), np.int8)
    for _ in range(8):
        batch = rng.choice(len(conn), size=7, replace=False)
        status[batch] = ERODED
        s.remove_elements(batch)
        same_surface(s, Surface(conn, eb, status=status, node_body=nb))
        faces, _, _ = boundary_faces(conn, status != ERODED)
        np.testing.assert_array_equal(s.faces, faces)
    # removing dead elements again changes nothing
    v = s.version
    assert s.remove_elements(np.flatnonzero(status == ERODED)) == 0 and s.version == v


def test_sync_follows_status_and_rebuilds_on_revival():
    x, conn, eb, nb = two_bodies()
    s = Surface(conn, eb, node_body=nb)
    status = np.zeros(len(conn), np.int8)
    assert not s.sync(status)
    status[[0, 5, 40]] = ERODED
    assert s.sync(status)
    same_surface(s, Surface(conn, eb, status=status, node_body=nb))
    status[5] = 0
    assert s.sync(status)
    same_surface(s, Surface(conn, eb, status=status, node_body=nb))


def test_everything_eroded_leaves_an_empty_surface():
    x, conn, eb, nb = two_bodies()
    s = Surface(conn, eb, node_body=nb)
    s.remove_elements(np.arange(len(conn)))
    assert s.n_faces == 0 and s.n_edges == 0 and s.n_nodes == 0
    assert s.mean_edge_length(x) == 0.0


def _compact_by_numpy(s):
    """The compact arrays by numpy's flatnonzero and gathers (what Surface._compact computed
    before its kernel), to check the kernel against, dtypes included."""
    from impactsim.mesh.topology import FACE_EDGES, LOCAL_FACES

    ids = np.flatnonzero(s.face_flag)
    face_elem = (ids // 4).astype(np.int64)
    face_local = (ids % 4).astype(np.int8)
    loc = face_local.astype(np.int64)
    faces = np.ascontiguousarray(s.conn[face_elem[:, None], LOCAL_FACES[loc]], dtype=np.int32)
    edge_mesh = np.flatnonzero(s.edge_count > 0).astype(np.int64)
    edges = np.ascontiguousarray(s.mesh_edges[edge_mesh], dtype=np.int32)
    edge_index = np.full(s.mesh_edges.shape[0], -1, dtype=np.int64)
    edge_index[edge_mesh] = np.arange(edge_mesh.shape[0])
    face_edges = np.ascontiguousarray(
        edge_index[s.elem_edges[face_elem[:, None], FACE_EDGES[loc]]], dtype=np.int64)
    nodes = np.flatnonzero(s.node_count > 0).astype(np.int32)
    edge_body = s.node_body_all[edges[:, 0]] if edges.shape[0] else np.zeros(0, np.int32)
    return {"faces": faces, "face_elem": face_elem, "face_local": face_local,
            "face_body": s.elem_body[face_elem], "face_edges": face_edges, "edges": edges,
            "edge_mesh": edge_mesh, "edge_body": edge_body, "nodes": nodes,
            "node_body": s.node_body_all[nodes]}


def test_compact_kernel_gives_the_arrays_of_the_numpy_formulas():
    x, conn, eb, nb = two_bodies()
    rng = np.random.default_rng(3)
    s = Surface(conn, eb, node_body=nb)
    for _ in range(12):
        for name, want in _compact_by_numpy(s).items():
            got = getattr(s, name)
            assert got.dtype == want.dtype, name
            np.testing.assert_array_equal(got, want, err_msg=name)
        s.remove_elements(rng.choice(len(conn), size=9, replace=False))


SURFACE_ARRAYS = ("faces", "face_elem", "face_local", "face_body", "face_edges", "edges",
                  "edge_body", "nodes", "node_body")


@pytest.mark.parametrize("element", ["tet", "hex8"])
def test_reconnect_gives_the_rebuilt_surface(element):
    """A separable bar pulled apart (tets), a block torn by its dragged end (hexes: 7 release
    steps, 112 new nodes): after every release step the surface updated in place
    (Surface.reconnect of the moved tets, HexSurface.reconnect of the moved hexes) has the
    arrays of a surface built afresh (with hexes: the self-contact keys and the penetration
    measure's tet cover too), and a run with it gives the same bits as a run that rebuilds
    the surface."""
    from impactsim.contact.hexes import ProxyTets
    from impactsim.fracture.separation import SeparationPass
    from tests.verification.test_node_separation import BAR, TEAR, _sim

    if element == "tet":
        text = BAR.format(fs=0.25, element=element, speed=300, measure="mean")
    else:  # the hex bar parts in two release steps; the torn block releases in seven
        text = TEAR.replace('mesher = "structured"', 'mesher = "structured"\nelement = "hex8"')
    text += "[contact]\nself_contact = true\n"
    names = SURFACE_ARRAYS + (("face_key", "edge_key") if element == "hex8" else ())
    runs = []
    for incremental in (True, False):
        sim, model = _sim(text)
        sp = next(p for p in sim.fracture_passes if isinstance(p, SeparationPass))
        sp.incremental = incremental
        ctx = next(p.ctx for p in sim.velocity_passes if hasattr(p, "ctx"))
        checked = 0
        for _ in range(160):
            sim.step()
            if incremental and sp.sep.moved:
                fresh = Surface.from_model(model)
                assert type(fresh) is type(ctx.surface)
                for name in names:
                    assert np.array_equal(getattr(ctx.surface, name), getattr(fresh, name)), name
                if element == "hex8":
                    proxy = ProxyTets(model)
                    assert np.array_equal(ctx.proxy.conn, proxy.conn)
                    assert np.array_equal(ctx.proxy.hconn, proxy.hconn)
                checked += 1
        runs.append((model.x.copy(), model.v.copy(), sp.sep.counts["new_nodes"], checked))
    assert runs[0][3] >= 5 and runs[0][2] > 0
    assert np.array_equal(runs[0][0], runs[1][0]) and np.array_equal(runs[0][1], runs[1][1])


def test_alive_changed_sees_any_erosion_and_revival():
    from impactsim.contact.surface import ERODED, alive_changed

    status = np.zeros(1000, np.int8)
    alive = np.ones(1000, bool)
    assert not alive_changed(status, alive)
    status[637] = ERODED
    assert alive_changed(status, alive)
    alive[637] = False
    assert not alive_changed(status, alive)
    status[637] = 0  # back to life
    assert alive_changed(status, alive)
