"""Names and units of the fields a frame can hold (output.fields in a case selects among them),
and of the quantities of history.csv; docs/outputs.md lists them (tests check it lists all).

`internal_energy` of history.csv is the internal energy of all live elements [J];
the cell field of a frame is the specific internal energy `specific_internal_energy` [J/kg].
"""

POINT_FIELDS = ("velocity", "displacement")
CELL_FIELDS = ("stress", "pressure", "von_mises", "plastic_strain", "temperature", "status", "body",
               "density", "specific_internal_energy", "cell_id", "jc_damage")
FRAME_FIELDS = POINT_FIELDS + CELL_FIELDS

FIELD_UNITS = {
    "velocity": "m/s", "displacement": "m", "stress": "Pa", "pressure": "Pa", "von_mises": "Pa",
    "plastic_strain": "", "temperature": "K", "status": "", "body": "", "density": "kg/m^3",
    "specific_internal_energy": "J/kg", "cell_id": "", "jc_damage": "",
    # the particles' own series (particles.pvd)
    "mass": "kg", "radius": "m",
}

# fields whose values are labels, drawn with one colour per value
STATUS_NAMES = {0: "intact", 1: "damaged (spalled)", 2: "fractured (loosened)", 3: "eroded"}
CATEGORICAL = {"status", "body", "cell_id"}

HISTORY_UNITS = {
    "time": "s", "step": "", "dt": "s", "kinetic_energy": "J", "internal_energy": "J",
    "viscous_energy": "J", "contact_dissipated": "J", "external_work": "J", "eroded_energy": "J",
    "half_step_energy": "J", "total_energy": "J", "momentum_x": "kg m/s", "momentum_y": "kg m/s", "momentum_z": "kg m/s",
    "contact_impulse": "N s", "contact_pairs": "", "max_penetration": "m", "wall_force": "N",
    "wall_nodes": "", "particles": "", "particle_kinetic_energy": "J",
    "particle_energy": "J", "particle_momentum_x": "kg m/s", "particle_momentum_y": "kg m/s",
    "particle_momentum_z": "kg m/s", "damaged": "", "fractured": "", "eroded_elements": "",
}


def history_unit(name: str) -> str:
    """Unit of a history column; per-body columns <body>.velocity_x are m/s, energy terms J."""
    if name in HISTORY_UNITS:
        return HISTORY_UNITS[name]
    last = name.rsplit(".", 1)[-1]
    if last.startswith("velocity_"):
        return "m/s"
    if last.startswith("momentum_"):
        return "kg m/s"
    if "energy" in last or last.endswith("_work") or last.endswith("dissipated"):
        return "J"
    if "force" in last:
        return "N"
    if "penetration" in last or last.endswith("length") or last.endswith("gap"):
        return "m"
    return ""


def header(name: str) -> str:
    """'time' -> 'time [s]'; a column without a unit keeps its bare name."""
    unit = history_unit(name)
    return f"{name} [{unit}]" if unit else name

# units of the keys of summary.json (written into it as its "units" table); keys are the last
# segment of a key path (bodies.<name>.mass -> "mass")
SUMMARY_UNITS = {
    "time": "s", "end_time": "s", "wall_seconds": "s", "seconds_to_first_step": "s",
    "seconds_per_pass": "s", "ns_per_element_step": "ns", "energy": "J",
    "energy_balance_error": "1 (relative to the initial total energy)",
    "mass": "kg", "momentum": "kg m/s", "mean_velocity": "m/s", "mean_velocity_all": "m/s",
    "residual_velocity": "m/s", "residual_speed": "m/s", "largest_fragment_mass": "kg",
    "mass_initial": "kg", "mass_final": "kg", "mass_error": "1 (relative)",
    "area": "m^2", "diameter_equivalent": "m", "extent": "m", "final_length": "m",
    "initial_length": "m", "foot_diameter": "m", "particle_mass": "kg",
    "particle_momentum": "kg m/s",
}
