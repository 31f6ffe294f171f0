"""Names of the fields a frame can hold (output.fields in a case selects among them)."""

POINT_FIELDS = ("velocity", "displacement")
CELL_FIELDS = ("stress", "pressure", "von_mises", "plastic_strain", "temperature", "status", "body",
               "density", "internal_energy")
FRAME_FIELDS = POINT_FIELDS + CELL_FIELDS
