"""Stability suite of the contact passes: grazing contact, meshes of very different sizes, a
sharp corner hitting a face.

Each asserts a finite state, no element inverted, momentum conserved, and a penetration (the
independent measure of impactsim.contact.diagnostics, every step) below a thousandth of the
finer mesh size. The `slow` variants (finer meshes, longer runs) run with `make hard`.
"""

import numpy as np
import pytest

from impactsim.case import load_case_text
from impactsim.mesh import mesh_body
from impactsim.solver.build import build_model
from impactsim.solver.loop import Simulation
from impactsim.solver.pipeline import build_passes


def box(name, size, h, position, velocity=(0, 0, 0), rotation=(0, 0, 0),
        material="aluminium-elastic"):
    return f"""
[[body]]
name = "{name}"
material = "{material}"
shape = "box"
size = [{size[0]}, {size[1]}, {size[2]}]
position = [{position[0]}, {position[1]}, {position[2]}]
rotation = [{rotation[0]}, {rotation[1]}, {rotation[2]}]
mesh_size = {h}
mesher = "structured"
velocity = [{velocity[0]}, {velocity[1]}, {velocity[2]}]
"""


def run(text, steps, friction=0.0):
    case = load_case_text("[run]\nend_time = 1.0\n" + text
                          + f"\n[contact]\nfriction = {friction}\n")
    model = build_model(case, [mesh_body(b, use_cache=False) for b in case.bodies])
    passes = build_passes(case, model)
    contact = [p for p in passes if p.name.startswith("contact.")]
    assert [p.name for p in contact] == ["contact.node-face", "contact.edge-edge"]
    sim = Simulation(model, passes, cfl=0.6)
    p0 = model.mass @ model.v
    deepest = 0.0
    pairs = 0
    for _ in range(steps):
        sim.step()
        row = contact[0].history(model)
        deepest = max(deepest, row["max_penetration"])
        pairs += row["contact_pairs"]
        assert np.all(np.isfinite(model.v)) and np.all(np.isfinite(model.x))
    assert np.all(model.vol > 0)
    scale = np.abs(p0).max() + np.abs(model.mass @ np.abs(model.v)).max()
    assert np.abs(model.mass @ model.v - p0).max() <= 1e-12 * scale
    return model, deepest, pairs


def grazing(h, steps):
    """A block slides onto a plate at 85 degrees from the plate's normal (200 m/s)."""
    a = np.radians(85.0)
    v = (200.0 * np.sin(a), 0.0, -200.0 * np.cos(a))
    text = (box("plate", (0.06, 0.03, 0.006), h, (0, 0, -0.003))
            + box("block", (0.01, 0.01, 0.01), h, (-0.015, 0, 0.005 + 2e-6), v))
    return run(text, steps)


def test_grazing_contact_at_85_degrees():
    model, deepest, pairs = grazing(0.002, 150)
    assert pairs > 0 and deepest < 1e-3 * 0.002
    # frictionless: the block slides on with most of its tangential speed
    block = model.node_body == 1
    assert (model.mass[block] @ model.v[block, 0]) / model.mass[block].sum() > 150.0


def test_grazing_contact_with_friction_slows_the_slide():
    a = np.radians(85.0)
    v = (200.0 * np.sin(a), 0.0, -200.0 * np.cos(a))
    text = (box("plate", (0.06, 0.03, 0.006), 0.002, (0, 0, -0.003))
            + box("block", (0.01, 0.01, 0.01), 0.002, (-0.015, 0, 0.005 + 2e-6), v))
    model, deepest, pairs = run(text, 150, friction=0.5)
    block = model.node_body == 1
    vx = (model.mass[block] @ model.v[block, 0]) / model.mass[block].sum()
    assert deepest < 1e-3 * 0.002 and vx < 200.0 * np.sin(a) - 1.0


def test_meshes_of_very_different_sizes():
    # a finely meshed block (0.5 mm) on a coarsely meshed plate (5 mm), and the other way round
    for fine_on_coarse in (True, False):
        hp, hb = (0.005, 0.0005) if fine_on_coarse else (0.0005, 0.005)
        plate_size = (0.02, 0.02, 0.005) if fine_on_coarse else (0.01, 0.01, 0.002)
        text = (box("plate", plate_size, hp, (0, 0, -plate_size[2] / 2))
                + box("block", (0.005, 0.005, 0.005), hb, (0.0013, -0.0007, 0.0025 + 1e-6),
                      (0, 0, -100.0)))
        model, deepest, pairs = run(text, 60)
        assert pairs > 0 and deepest < 1e-3 * 0.0005, fine_on_coarse


def test_sharp_corner_hits_a_face():
    # a cube standing on a corner (body diagonal along z) falls on a plate at 200 m/s
    tilt = np.degrees(np.arctan(np.sqrt(0.5)))
    d = 0.01 * np.sqrt(3) / 2
    text = (box("plate", (0.04, 0.04, 0.008), 0.002, (0, 0, -0.004))
            + box("cube", (0.01, 0.01, 0.01), 0.0025, (0.0011, 0.0007, d + 1e-6), (0, 0, -200.0),
                  rotation=(45.0 * np.pi / 180, tilt * np.pi / 180, 0.0)))
    model, deepest, pairs = run(text, 120)
    assert pairs > 0 and deepest < 1e-3 * 0.002


@pytest.mark.slow
def test_grazing_contact_long_and_fine():
    model, deepest, pairs = grazing(0.001, 1500)
    assert pairs > 0 and deepest < 1e-3 * 0.001
