"""The fracture, distortion, node-separation, self-contact and hex terms of the cost estimate
(impactsim.case.estimate, docs/estimates.md): each pass counted once, in units of the calibrated
element-step, and switched on by what switches the pass on in a run. Figures, not timings."""

import pytest

from impactsim.case import crush as C
from impactsim.case import estimate as E
from impactsim.case import load_case_text
from impactsim.fracture.passes import fracture_wanted

SPEED = {"ns_per_element_step": 100.0, "seconds_per_step": 0.0}

SCENE = """
[run]
name = "scene"
end_time = "2 us"
[[material]]
name = "plate-al"
library = "al-6061-t6"
failure = {failure}
[[body]]
name = "plate"
material = "plate-al"
shape = "plate"
size = ["8 mm", "8 mm", "2 mm"]
position = [0, 0, "-1 mm"]
mesh_size = "1 mm"
mesher = "structured"
element = "{element}"
[[body]]
name = "ball"
material = "al-ideal-plastic"
shape = "box"
size = ["2 mm", "2 mm", "2 mm"]
position = [0, 0, "1.1 mm"]
mesh_size = "1 mm"
mesher = "structured"
velocity = [0, 0, "-5 km/s"]
[contact]
passes = ["node-face"]
self_contact = {self_contact}
{fracture}
"""

NONE = '{ spall_strength = "none", loosening = "none" }'
SEPARATE = '{ fracture_strain = 1.0, spall_strength = "none", loosening = "none" }'


def scene(failure=NONE, element="tet", self_contact="false", fracture=""):
    return load_case_text(SCENE.format(failure=failure, element=element,
                                       self_contact=self_contact, fracture=fracture))


def test_node_separation_is_counted_though_the_material_has_no_spall_or_erosion():
    """A fracture strain alone (node separation) runs the fracture passes in a run; the estimate
    counts the separation pass over the separable body's elements every step, and a separable
    body's element loop SEPARABLE_COST times a tet's (its own corner nodes)."""
    case = scene(SEPARATE)
    plate = case.materials["plate-al"].failure
    assert not plate.active and fracture_wanted(case)  # what the old gate missed
    est = E.estimate_cost(case, dict(SPEED), share=1.0)
    n, ball = est.per_body["plate"], est.per_body["ball"]
    # the separation pass over the plate, the criteria and particle passes over every element
    assert est.seconds["fracture"] == pytest.approx(
        est.steps * (n * E.SEPARATION_TE + (n + ball) * E.FRACTURE_TE) * 1e-7)
    plain = E.estimate_cost(scene(), dict(SPEED), share=1.0)
    assert "fracture" not in plain.seconds and not fracture_wanted(scene())
    # the element loop: only the plate's elements cost more
    per_step = (E.ELEMENT_TE * (n * E.SEPARABLE_COST + ball)
                + E.NODES_TE * (n * E.SEPARABLE_COST + ball)) * 1e-7
    assert est.seconds["elements"] == pytest.approx(est.steps * per_step, rel=1e-9)


def test_distortion_checks_count_once_per_interval_at_most_once_a_step():
    every = E.estimate_cost(scene(fracture='[fracture]\ndistortion_interval = "0.001 ns"'),
                            dict(SPEED), share=1.0)
    n = sum(every.per_body.values())
    criteria = every.steps * n * E.FRACTURE_TE * 1e-7  # the passes run for the check
    assert every.seconds["fracture"] == pytest.approx(
        criteria + every.steps * n * E.DISTORTION_TE[False] * 1e-7)  # one check a step at most
    sparse = E.estimate_cost(scene(fracture='[fracture]\ndistortion_interval = "0.5 us"'),
                             dict(SPEED), share=1.0)
    assert sparse.seconds["fracture"] == pytest.approx(
        criteria + 4 * n * E.DISTORTION_TE[False] * 1e-7)


def test_self_contact_costs_more_per_face():
    alone = E.estimate_cost(scene(), dict(SPEED), share=1.0)
    self_ = E.estimate_cost(scene(self_contact="true"), dict(SPEED), share=1.0)
    assert self_.steps == alone.steps
    assert self_.seconds["contact"] == pytest.approx(
        alone.seconds["contact"] * E.SELF_CONTACT_TE_PER_FACE / E.CONTACT_TE_PER_FACE)


def test_a_failing_hex_body_costs_the_scalar_path_and_its_fracture_criteria():
    spall = '{ spall_strength = "1.6 GPa", loosening = 0.03 }'
    hexes = E.estimate_cost(scene(spall, "hex8"), dict(SPEED), share=1.0)
    tets = E.estimate_cost(scene(spall), dict(SPEED), share=1.0)
    n, ball = hexes.per_body["plate"], hexes.per_body["ball"]
    assert E.HEX_FAILING_COST > E.HEX_COST
    elements = (E.ELEMENT_TE * (n * E.HEX_FAILING_COST + ball) + E.NODES_TE * (n + ball)) * 1e-7
    assert hexes.seconds["elements"] == pytest.approx(hexes.steps * elements, rel=1e-9)
    assert hexes.seconds["fracture"] == pytest.approx(
        hexes.steps * (n * E.HEX_FRACTURE_TE + ball * E.FRACTURE_TE) * 1e-7)
    m = tets.per_body["plate"]
    assert tets.seconds["fracture"] == pytest.approx(tets.steps * (m + ball) * E.FRACTURE_TE
                                                     * 1e-7)
    intact = E.estimate_cost(scene(NONE, "hex8"), dict(SPEED), share=1.0)
    assert intact.seconds["elements"] / intact.steps < hexes.seconds["elements"] / hexes.steps


def test_node_separation_bounds_the_foot_strain_by_the_fracture_strain():
    """At 5 km/s the plate's foot would flow far beyond 2; node separation frees its cells
    between the fracture strain eps_f (the "max" measure) and 2 eps_f (the "mean" measure with
    an unstrained neighbour): the estimate takes eps_f and 1.5 eps_f."""
    free = {c.body: c for c in C.crushes(scene())}
    cut = {c.body: c for c in C.crushes(scene(SEPARATE))}
    assert free[0].strain > 2.0 and cut[0].strain == pytest.approx(1.5)
    assert cut[0].shrink == pytest.approx(C.shrink_of(1.5))
    assert cut[1].strain == free[1].strain  # the ball's material has no fracture strain
    strict = {c.body: c for c in C.crushes(scene(
        SEPARATE, fracture='[fracture]\nseparation_measure = "max"'))}
    assert strict[0].strain == 1.0 and strict[0].shrink < cut[0].shrink
