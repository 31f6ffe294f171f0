"""The thermal entries of the material library reproduce the correlations their sources cite."""

import math
import tomllib

import pytest

from impactsim.materials import library


def _table(name):
    entry = tomllib.loads(library.LIBRARY_FILE.read_text())[name]
    return [tuple(float(v) for v in row.split()) for row in entry["conductivity_table"]]


def fink_uo2(temperature, porosity=0.05):
    """Fink (2000), J. Nucl. Mater. 279, 1-18: fully dense UO2, times (1 - p) / (1 + 2 p)."""
    t = temperature / 1000.0
    k = 100.0 / (7.5408 + 17.692 * t + 3.6142 * t * t) + 6400.0 / t**2.5 * math.exp(-16.35 / t)
    return k * (1.0 - porosity) / (1.0 + 2.0 * porosity)


def matpro_zry4(temperature):
    """MATPRO (NUREG/CR-6150 Rev. 2): Zircaloy thermal conductivity, a cubic in T."""
    return 7.51 + 2.09e-2 * temperature - 1.45e-5 * temperature**2 + 7.67e-9 * temperature**3


@pytest.mark.parametrize("name,law", [("uo2", fink_uo2), ("zircaloy-4", matpro_zry4)])
def test_conductivity_table_follows_the_cited_correlation(name, law):
    rows = _table(name)
    assert len(rows) >= 4
    for temperature, k in rows:
        assert k == pytest.approx(law(temperature), rel=5e-3), (name, temperature)
