"""The keys of a quasi-static case (``[run] analysis = "quasistatic"``), in the key-table form
of ``spec.py`` (the reader checks names and converts values with it; the reference renders it).
[run], [[material]] and [output].directory are the dynamic case's tables."""

from __future__ import annotations

from impactsim.case.spec import MATERIAL, REQUIRED, COMPUTED, RUN, Key, Table

QS_SHAPES = ("box", "cylinder", "tube", "sphere", "file")
QS_SHAPE_KEYS = {
    "box": ("size",),
    "cylinder": ("radius", "diameter", "height"),
    "tube": ("radius", "diameter", "inner_radius", "height"),
    "sphere": ("radius", "diameter"),
    "file": ("path", "scale"),
}
CONDITION_KEYS = ("temperature", "flux", "exchange", "displacement", "traction", "pressure")

QS_RUN = Table("run", "Run control of a quasistatic case: end_time, and load steps as `steps` "
               "(a count of equal steps up to end_time) or `times`.", tuple(
    k for k in RUN.keys if k.name in ("name", "analysis", "end_time")) + (
    Key("steps", "int", "quasistatic: number of equal load steps up to end_time (>= 1).", 1),
    Key("times", "quantity-list", "quasistatic: the load step end times (increasing, the last "
        "one end_time).", None, dim="time"),
))

QUASISTATIC = Table("quasistatic", "Solver settings of the quasi-static analysis.", (
    Key("element", "choice", "tet4 (linear) or tet10 (quadratic: better contact pressures).",
        "tet10", choices=("tet4", "tet10")),
    Key("heat", "choice", "transient (backward Euler between load steps, c rho dT/dt) or "
        "steady conduction at each step.", "transient", choices=("transient", "steady")),
    Key("relaxation", "number", "Relaxation omega of eq. 7 of [G15], in (0, 2) (Aitken's "
        "first value when aitken = true).", 0.5),
    Key("aitken", "bool", "Adapt omega by Aitken's delta-squared (Irons-Tuck).", True),
    Key("anderson", "int", "Anderson acceleration of the interface values (gaps and pressures "
        "of every interface) over this many past iterates, restarted when an active set "
        "changes; 0: off (>= 0).", 0),
    Key("coarse", "bool", "Coarse step along the anchor tree after each Schwarz iteration: "
        "each body held by its contacts moves with its support and passes on at once the "
        "force its subtree carries (columns of bodies).", True),
    Key("solver", "choice", "Elastic solver of each body: direct (SuperLU, factorised once), "
        "amg (pyamg smoothed aggregation + conjugate gradients, for bodies too large to "
        "factorise), auto (amg above direct_limit free dofs).", "auto",
        choices=("auto", "direct", "amg")),
    Key("direct_limit", "int", "auto: bodies with more displacement dofs than this use amg.",
        300000),
    Key("max_iterations", "int", "Schwarz iterations per load step before giving up (>= 1).",
        500),
    Key("gap_tolerance", "number", "Stop when the gap mismatch, relative to the largest "
        "displacement, is below this (> 0).", 1e-4),
    Key("pressure_tolerance", "number", "... and the pressure mismatch, relative to the "
        "largest contact pressure, is below this (> 0).", 1e-3),
    Key("heat_tolerance", "number", "Heat: stop when the interface temperatures change by "
        "less than this, relative (> 0).", 1e-7),
    Key("max_heat_iterations", "int", "Heat iterations per load step before giving up.", 300),
    Key("regularization", "number", "Weak springs eps diag(K) towards the previous iterate "
        "(floating bodies; no force at convergence), >= 0.", 1e-6),
    Key("workers", "int", "Worker processes (Dask LocalCluster) for the bodies; 0 = in this "
        "process. --workers and --scheduler on the command line override it.", 0),
))

PAIR = Table("pair", "Properties of the contacts between bodies matching two name patterns "
             "(shell-style: \"pellet*\"). The first matching entry applies; with detect = false "
             "only pairs of listed bodies are searched.", (
    Key("bodies", "string-list", "Two body names or patterns."),
    Key("friction", "number", "Coulomb friction coefficient mu (>= 0): stick while the "
        "tangential traction is below mu times the pressure, slip at it; 0 (the default): "
        "frictionless, free tangential slip; inf (or \"inf\"): stuck, tangentially tied.", 0.0),
    Key("conductance", "quantity", "Gap heat-transfer coefficient h (>= 0; 0: no heat "
        "crosses).", 0.0, dim="heat_transfer"),
    Key("gap_tolerance", "quantity", "Surfaces closer than this are in contact.", COMPUTED,
        dim="length", default_doc="[contact].gap_tolerance"),
    Key("tied", "bool", "Bonded contact: the surfaces stay together (tension allowed, no "
        "active set).", False),
    Key("robin", "number", "Robin (mixed) conditions instead of kinematic / force sides: the "
        "spring stiffness alpha in Pa/m of the contact law both bodies see each iteration, "
        "p = p_other - alpha gap (about the stiffness of the softer side's contact surface; "
        "docs/quasistatic.md). 0: the Dirichlet-Neumann split of [G15]. Frictionless pairs "
        "only.", 0.0),
), array=True)

QS_CONTACT = Table("contact", "Contact between bodies (quasistatic).", (
    Key("detect", "bool", "Find the contacts: facets with opposed normals closer than the gap "
        "tolerance (several patches per pair). false: only pairs listed in [[contact.pair]].",
        True),
    Key("gap_tolerance", "quantity", "Surfaces closer than this are in contact (> 0).",
        COMPUTED, dim="length", default_doc="1 % of the smallest mesh size"),
    PAIR,
))

REGION_PLANE = Table("plane", "Boundary facets within `tolerance` of a plane.", (
    Key("point", "vector", "A point of the plane.", dim="length"),
    Key("normal", "vector", "Plane normal.", dim="dimensionless"),
), default="none (off)")

REGION_BOX = Table("box", "Boundary facets with all vertices in the box.", (
    Key("lo", "vector", "Lower corner.", dim="length"),
    Key("hi", "vector", "Upper corner.", dim="length"),
), default="none (off)")

REGION_CYLINDER = Table("cylinder", "Boundary facets within `tolerance` of a cylindrical "
                        "surface (the outside of a tube).", (
    Key("point", "vector", "A point of the axis.", dim="length"),
    Key("axis", "vector", "Axis direction.", dim="dimensionless"),
    Key("radius", "quantity", "Radius of the surface.", dim="length"),
), default="none (off)")

BOUNDARY = Table("boundary", "A boundary condition on a named surface part, selected by "
                 "exactly one of `plane`, `box`, `cylinder` (world coordinates; copies shift them with "
                 "themselves) or `group` (a gmsh physical group of a mesh file). Conditions: "
                 "temperature, flux, exchange (+ ambient), displacement, traction, pressure "
                 "(one or more; heat and mechanical ones may be combined).", (
    Key("name", "string", "Name of the surface part.", COMPUTED,
        default_doc="`boundary<index>`"),
    REGION_PLANE,
    REGION_BOX,
    REGION_CYLINDER,
    Key("group", "string", "gmsh physical group (shape = \"file\").", None),
    Key("tolerance", "quantity", "Distance tolerance of plane, box and cylinder.", COMPUTED,
        dim="length", default_doc="1 % of the mesh size"),
    Key("temperature", "quantity", "Prescribed temperature.", None, dim="temperature"),
    Key("flux", "quantity", "Heat flux into the body.", None, dim="heat_flux"),
    Key("exchange", "quantity", "Heat exchange coefficient alpha of alpha (T - ambient).", None,
        dim="heat_transfer"),
    Key("ambient", "quantity", "Ambient temperature of `exchange`.", COMPUTED,
        dim="temperature", default_doc="required with exchange"),
    Key("displacement", "length-or-free", "Prescribed displacement components.", None),
    Key("traction", "vector", "Traction vector.", None, dim="pressure"),
    Key("pressure", "quantity", "Pressure (compressive, along the inward normal).", None,
        dim="pressure"),
    Key("ramp", "bool", "Scale mechanical values by t / end_time over the load steps.", False),
), array=True)

COPIES = Table("copies", "Repeat the body: `count` bodies named <name>1..<name>N, each "
               "shifted by `offset` from the previous (one mesh for all).", (
    Key("count", "int", "Number of bodies (>= 1)."),
    Key("offset", "vector", "Shift from one copy to the next.", dim="length"),
), default="none (off)")

REFINE = Table("refine", "Smaller elements within `radius` of `point` (a contact patch).", (
    Key("point", "vector", "Centre, in the body's own frame (before placement).", dim="length"),
    Key("size", "quantity", "Element size there.", dim="length"),
    Key("radius", "quantity", "Radius of the refined ball.", dim="length"),
), default="none (off)")

CLIP = Table("clip", "Keep the part of the shape inside this box (own frame): symmetric "
             "models.", (
    Key("lo", "vector", "Lower corner.", dim="length"),
    Key("hi", "vector", "Upper corner.", dim="length"),
), default="none (off)")

QS_BODY = Table("body", "A body of a quasistatic case: a primitive or a mesh file, one "
                "material, boundary conditions on named surface parts.", (
    Key("name", "string", "Name of the body.", COMPUTED, default_doc="`body<index>`"),
    Key("material", "string", "A [[material]] name, or a library name."),
    Key("shape", "choice", "Primitive, or file.", choices=QS_SHAPES),
    Key("size", "vector", "box: [lx, ly, lz].", REQUIRED, dim="length",
        default_doc="required (box)"),
    Key("radius", "quantity", "cylinder, tube (outer), sphere.", REQUIRED, dim="length",
        default_doc="required (cylinder, tube, sphere)"),
    Key("diameter", "quantity", "Instead of radius.", None, dim="length"),
    Key("inner_radius", "quantity", "tube: inner radius.", REQUIRED, dim="length",
        default_doc="required (tube)"),
    Key("height", "quantity", "cylinder, tube: length along z.", REQUIRED, dim="length",
        default_doc="required (cylinder, tube)"),
    Key("path", "path", "file: mesh file, relative to the case file.", REQUIRED,
        default_doc="required (file)"),
    Key("scale", "number", "file: factor from file units to m.", 1.0),
    Key("position", "vector", "Centre of the primitive.", (0.0, 0.0, 0.0), dim="length"),
    Key("rotation", "vector", "Intrinsic x-y-z Euler angles.", (0.0, 0.0, 0.0), dim="angle"),
    Key("mesh_size", "quantity", "Element edge length.", REQUIRED, dim="length",
        default_doc="required (not for file)"),
    Key("mesher", "choice", "gmsh, or structured (box only).", "gmsh",
        choices=("gmsh", "structured")),
    Key("initial_temperature", "quantity", "Initial (and, without heat conditions, constant) "
        "temperature.", COMPUTED, dim="temperature",
        default_doc="the material's initial_temperature"),
    Key("heat_source", "quantity", "Volumetric heat source Phi.", 0.0, dim="power_density"),
    Key("centering_axis", "vector", "Tie the body to its reference position across this axis "
        "by the weak springs (quasistatic.regularization) instead of to its last iterate: for "
        "bodies whose sideways position nothing fixes (pellets in a column).", None,
        dim="dimensionless"),
    COPIES,
    REFINE,
    CLIP,
    BOUNDARY,
), array=True)

QS_OUTPUT = Table("output", "Where results go.", (
    Key("directory", "path", "Output folder.", None, default_doc="`out/<run.name>`"),
))

QS_ROOT = Table("", "A quasistatic case file.", (QS_RUN, QUASISTATIC, MATERIAL, QS_BODY,
                                                 QS_CONTACT, QS_OUTPUT))
