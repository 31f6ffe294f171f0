"""Which tet formulation a run uses: `run.element = "auto"` (the default) resolved from the
materials, and the one-line hint `impactsim check` prints when a case asks for a locking element.

The evidence (docs/accuracy.md, taylor-mesh study; docs/validation.md): in the plastic flow of
a Taylor bar the constant-strain tet (tet4) locks volumetrically. Its foot diameter converges
from far below (OFHC copper at 190 m/s: 11.9 mm at h = 1.27 mm, 12.75 mm at 0.635 mm, still
moving), while the averaged-nodal-pressure tet (anp, Bonet & Burton 1998) is within 1.9 % of
its converged 14.4 mm at 1.27 mm already, and matches a hexahedral mesh (14.2 mm) and two other
codes' 42CrMo4 bar within about 1 %. Per step anp costs about 1.2 times tet4 (two more passes
over memory), and at equal error it is far cheaper. In elastic problems the two agree (the
bar-column and bar-free studies: equal stress and duration; tet4's rebound converges a little
faster), so tet4 stays the choice there: locking needs near-incompressible (plastic) flow.

But anp gives a single cell no volumetric stiffness of its own (its EOS sees its nodes'
patches), and where bodies press into each other it let cells be crushed into slivers: with
anp the coarse two-cylinders case stopped at 7 us (time step collapsed to 7e-11 s in the
striker) and the coarse sphere-plate at 3.1 us (6.5e-11 s in the plate), both of which run to
their end with tet4. Rigid walls do not do that (Taylor bars with anp: no collapse, energy to
4e-4).

Rule: "anp" when a body's material has a plastic strength model (ideal-plastic or
johnson-cook) and no contact between bodies runs (walls are fine), else "tet4".
"""

from __future__ import annotations

PLASTIC_MODELS = ("ideal-plastic", "johnson-cook")


def _body_contact(case) -> bool:
    """True when contact passes run between bodies (as impactsim.case.describe.has_contact)."""
    return (len(case.bodies) >= 2 or case.contact.self_contact) and bool(case.contact.passes)


def _plastic_materials(case) -> list[str]:
    used = dict.fromkeys(b.material for b in case.bodies)
    return [n for n in used if case.materials[n].strength.model in PLASTIC_MODELS]


def resolve_element(case) -> str:
    """The tet formulation the run uses: run.element, or for "auto" the rule above."""
    element = case.run.element
    if element != "auto":
        return element
    return "anp" if _plastic_materials(case) and not _body_contact(case) else "tet4"


def element_reason(case) -> str:
    """Why resolve_element chose what it did, in a few words (for `impactsim check`)."""
    if case.run.element != "auto":
        return "run.element"
    plastic = _plastic_materials(case)
    if not plastic:
        return "auto: elastic materials only"
    if _body_contact(case):
        return "auto: contact between bodies"
    return f"auto: plastic material {plastic[0]!r}"


def locking_hint(case) -> str | None:
    """One line when the case asks for tet4 with plastic materials (volumetric locking)."""
    plastic = _plastic_materials(case)
    if case.run.element != "tet4" or not plastic:
        return None
    if _body_contact(case):
        return (f'run.element = "tet4" locks in plastic flow (material {plastic[0]!r}), but '
                '"anp" let cells be crushed to slivers under contact between bodies; check the '
                "converged shapes (docs/physics.md)")
    return (f'run.element = "tet4" locks in plastic flow (material {plastic[0]!r}): Taylor-bar '
            'feet come out 12-14 % narrow; "anp" (the default here) does not '
            "(docs/validation.md)")
