"""docs/outputs.md lists every frame field and history column with its unit, and the units of
history.csv headers and summary.json are the ones of output/fields.py."""

from pathlib import Path

from impactsim.output.fields import FIELD_UNITS, FRAME_FIELDS, HISTORY_UNITS, header, history_unit
from impactsim.results import split_header

DOC = (Path(__file__).resolve().parents[2] / "docs" / "outputs.md").read_text()


def test_every_field_and_column_is_documented():
    for name in FRAME_FIELDS:
        assert f"`{name}`" in DOC, name
    for name in HISTORY_UNITS:
        assert f"`{name}`" in DOC or f"`{name.rsplit('_', 1)[0]}_x`" in DOC, name


def test_headers_carry_units_and_read_back():
    assert header("time") == "time [s]" and header("step") == "step"
    assert header("sphere.velocity_z") == "sphere.velocity_z [m/s]"
    assert history_unit("contact_impulse") == "N s"
    assert split_header("kinetic_energy [J]") == ("kinetic_energy", "J")
    assert FIELD_UNITS["specific_internal_energy"] == "J/kg" and HISTORY_UNITS["internal_energy"] == "J"
