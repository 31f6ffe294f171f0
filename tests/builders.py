"""Small models built in Python for tests: schema objects and structured meshes, no case file."""

from __future__ import annotations

import numpy as np

from impactsim.case.schema import EOS, Body, Case, Material, Output, Run, Strength
from impactsim.mesh.structured import structured_box
from impactsim.solver.build import build_model

STEEL = Material(name="steel", density=7850.0, shear_modulus=200e9 / 2.6,
                 bulk_modulus=200e9 / (3 * 0.4), specific_heat=450.0)


def material(**kw) -> Material:
    """A steel-like material; keyword overrides of Material fields."""
    base = dict(name="m", density=STEEL.density, shear_modulus=STEEL.shear_modulus,
                bulk_modulus=STEEL.bulk_modulus, specific_heat=450.0)
    base.update(kw)
    return Material(**base)


def box_case(mat: Material, size=(1.0, 1.0, 1.0), h=0.5, velocity=(0.0, 0.0, 0.0), end=1e-3,
             **run) -> Case:
    body = Body(name="box", material=mat.name, shape="box", dimensions={"size": size},
                mesh_size=h, mesher="structured", velocity=velocity)
    return Case(source=None, run=Run(name="t", end_time=end, **run), materials={mat.name: mat},
                bodies=[body], output=Output())


def box_model(mat: Material, size=(1.0, 1.0, 1.0), h=0.5, **kw):
    case = box_case(mat, size, h, **kw)
    pts, tets = structured_box(size, h)
    return build_model(case, [(pts, tets)]), case
