"""The case-file keys, in one machine-readable table.

Every table of the case file and every key in it, with its type (and physical dimension), its
default and its meaning. The reader (``impactsim.case.read``) checks names and converts values with
it, and the reference (``impactsim.case.reference``, docs/case-reference.md) is rendered from it,
so the accepted keys and their documentation cannot drift apart. Defaults are taken from the
dataclasses of ``impactsim.case.schema`` where those have one.
"""

from __future__ import annotations

from dataclasses import MISSING, dataclass, fields

from impactsim.case import schema


class _Marker:
    def __init__(self, name: str):
        self.name = name

    def __repr__(self) -> str:
        return self.name


REQUIRED = _Marker("REQUIRED")  # the key must be given
COMPUTED = _Marker("COMPUTED")  # the default depends on other keys (see default_doc)

# kinds of values:
#   quantity (dim)        number in SI or "<number> <unit>"
#   vector (dim)          3 quantities
#   quantity-list (dim)   any number of quantities
#   number                dimensionless float
#   number-list (length)  fixed number of dimensionless floats
#   int, bool, string, path
#   choice (choices), choice-list (choices), string-list
#   velocity-or-free      3 velocities, each may be "free"
#   length-or-free        3 lengths, each may be "free" (prescribed displacements)
#   length-or-vector      a length (cube12) or 3 lengths (box, plate)
#   steps-or-time         an integer (steps) or a time ("0.5 us", or a float in s)
KINDS = {"quantity", "vector", "quantity-list", "number", "number-list", "int", "bool", "string",
         "path", "choice", "choice-list", "string-list", "velocity-or-free", "length-or-vector",
         "length-or-free", "steps-or-time"}


@dataclass(frozen=True)
class Key:
    name: str
    kind: str
    doc: str
    default: object = REQUIRED
    dim: str = ""
    choices: tuple[str, ...] = ()
    default_doc: str = ""  # shown in the reference instead of the default value
    length: int = 0  # number-list

    def __post_init__(self) -> None:
        assert self.kind in KINDS, self.kind


@dataclass(frozen=True)
class Table:
    name: str
    doc: str
    keys: tuple[Key | Table, ...]
    array: bool = False  # an array of tables ([[body]])
    shorthands: tuple[str, ...] = ()  # strings accepted in place of the table ("all", "none")
    default: object = None  # for the reference: absent table means ...

    def get(self, name: str) -> Key | Table | None:
        for item in self.keys:
            if item.name == name:
                return item
        return None

    @property
    def names(self) -> list[str]:
        return [item.name for item in self.keys]


def _d(cls: type, name: str) -> object:
    """The default of a schema dataclass field (for one source of defaults)."""
    for f in fields(cls):
        if f.name == name:
            if f.default is not MISSING:
                return f.default
            if f.default_factory is not MISSING:
                return f.default_factory()
    raise KeyError(f"{cls.__name__}.{name} has no default")


ELEMENTS = ("auto", "tet4", "anp")
STRENGTH_MODELS = ("elastic", "ideal-plastic", "johnson-cook")
EOS_MODELS = ("linear", "mie-gruneisen")
EROSION_CRITERIA = ("plastic-strain", "jc-damage", "principal-strain", "fractured")
SHAPES = ("box", "plate", "cylinder", "sphere", "file", "cube12")
MESHERS = ("gmsh", "structured")
BODY_ELEMENTS = ("tet", "hex8")
HOURGLASS_FORMS = ("viscous", "stiffness")
CONTACT_PASSES = ("node-face", "edge-edge")
EROSION_REGIONS = ("surface", "anywhere")
SEPARATION_MEASURES = ("mean", "max")
SEPARATION_RELEASES = ("faces", "nodes")
ELASTIC_CONSTANTS = ("youngs_modulus", "poisson_ratio", "shear_modulus", "bulk_modulus")

# which shape keys a shape takes; the body's other keys apply to every shape
SHAPE_KEYS: dict[str, tuple[str, ...]] = {
    "box": ("size",),
    "plate": ("size",),
    "cylinder": ("radius", "diameter", "height", "length", "axis"),
    "sphere": ("radius", "diameter"),
    "file": ("path", "scale"),
    "cube12": ("size",),
}
STRUCTURED_SHAPES = ("box", "plate", "cube12")
UNMESHED_SHAPES = ("file", "cube12")  # shapes whose mesh_size is optional

# which strength / EOS keys a model takes (besides `model`)
STRENGTH_KEYS: dict[str, tuple[str, ...]] = {
    "elastic": (),
    "ideal-plastic": ("yield_stress",),
    "johnson-cook": ("A", "B", "n", "C", "m", "strain_rate_ref", "room_temperature",
                     "melt_temperature"),
}
EOS_KEYS: dict[str, tuple[str, ...]] = {
    "linear": ("c0",),
    "mie-gruneisen": ("c0", "s", "gamma0"),
}

RUN = Table("run", "Time integration and run control.", (
    Key("analysis", "choice", "Analysis type: explicit dynamics, or quasi-static thermoelastic "
        "contact of many bodies (its own keys: docs/quasistatic.md).", "dynamic",
        choices=("dynamic", "quasistatic")),
    Key("name", "string", "Name of the run; names the default output folder `out/<name>`.",
        COMPUTED, default_doc="the case file's stem"),
    Key("end_time", "quantity", "Simulated time at which the run ends (> 0).", dim="time"),
    Key("cfl", "number", "Courant number C_cfl of the time step, in (0, 0.9]: the stable-step estimate "
        "(smallest altitude / wave speed) goes unstable near 1 (energy gained at 0.99).",
        _d(schema.Run, "cfl")),
    Key("element", "choice", "Element formulation: constant-strain tet, or the averaged "
        "nodal-pressure tet (Bonet & Burton 1998) against volumetric locking; auto: anp when "
        "a body's material is plastic, else tet4 (docs/physics.md).",
        _d(schema.Run, "element"), choices=ELEMENTS),
    Key("q_quadratic", "number", "Quadratic artificial viscosity coefficient C_q (>= 0).",
        _d(schema.Run, "q_quadratic")),
    Key("q_linear", "number", "Linear artificial viscosity coefficient C_l (>= 0).",
        _d(schema.Run, "q_linear")),
    Key("max_steps", "int", "Stop after this many steps (>= 1).", _d(schema.Run, "max_steps")),
    Key("dt_collapse", "number", "Stop when the time step falls below this fraction of the "
        "initial one (a collapsing element), in (0, 1).", _d(schema.Run, "dt_collapse")),
    Key("threads", "int", "Numba threads; 0 = automatic: one thread below 50 000 elements, all cores above.", _d(schema.Run, "threads")),
    Key("subcycle", "int", "Levels of subcycling, 0 (off) to 4: the tets of a part whose "
        "stable step is at least 2^k times the least are updated every 2^k steps, k <= "
        "subcycle; pays where regions of many parts are meshed much coarser than the finest "
        "cells (docs/physics.md, Subcycling).", _d(schema.Run, "subcycle")),
))

STRENGTH = Table("strength", "Deviatoric strength model. Keys other than `model` apply to one "
                 "model only: ideal-plastic takes yield_stress; johnson-cook takes A, B, n, C, m, "
                 "strain_rate_ref, room_temperature, melt_temperature.", (
    Key("model", "choice", "Strength model.", _d(schema.Strength, "model"),
        choices=STRENGTH_MODELS),
    Key("yield_stress", "quantity", "Yield stress Y0 of ideal plasticity (> 0); required for "
        "ideal-plastic.", REQUIRED, dim="pressure", default_doc="required (ideal-plastic)"),
    Key("A", "quantity", "Johnson-Cook initial yield stress (> 0); required for johnson-cook.",
        REQUIRED, dim="pressure", default_doc="required (johnson-cook)"),
    Key("B", "quantity", "Johnson-Cook hardening modulus (>= 0); required for johnson-cook.",
        REQUIRED, dim="pressure", default_doc="required (johnson-cook)"),
    Key("n", "number", "Johnson-Cook hardening exponent.", _d(schema.Strength, "n")),
    Key("C", "number", "Johnson-Cook strain-rate coefficient.", _d(schema.Strength, "C")),
    Key("m", "number", "Johnson-Cook thermal softening exponent.", _d(schema.Strength, "m")),
    Key("strain_rate_ref", "quantity", "Reference plastic strain rate eps_dot0 (> 0).",
        _d(schema.Strength, "strain_rate_ref"), dim="rate"),
    Key("room_temperature", "quantity", "Johnson-Cook reference (room) temperature.",
        _d(schema.Strength, "room_temperature"), dim="temperature"),
    Key("melt_temperature", "quantity", "Johnson-Cook melting temperature; the default means "
        "no thermal softening.", _d(schema.Strength, "melt_temperature"), dim="temperature"),
), default="elastic")

EOS = Table("eos", "Pressure model. linear: p = K (1 - V/V0) with the bulk modulus of the "
            "material (c0 optional, K = rho c0^2 if K is not given); mie-gruneisen: linear "
            "Us-up Hugoniot with Grueneisen coefficient (c0, s, gamma0 required).", (
    Key("model", "choice", "Equation of state.", _d(schema.EOS, "model"), choices=EOS_MODELS),
    Key("c0", "quantity", "Bulk sound speed (Hugoniot intercept).", 0.0, dim="velocity",
        default_doc="required (mie-gruneisen)"),
    Key("s", "number", "Hugoniot slope s of Us = c0 + s up (>= 0).", 0.0,
        default_doc="required (mie-gruneisen)"),
    Key("gamma0", "number", "Grueneisen coefficient at the reference density (>= 0).", 0.0,
        default_doc="required (mie-gruneisen)"),
), default="linear")

FAILURE = Table("failure", "Fracture and erosion data; a mechanism is off when its key is "
                "absent. The string \"none\" in place of the table switches off everything a "
                "library entry brings; a key set to \"none\" (e.g. `spall_strength = \"none\"`) "
                "switches off that one mechanism of the library entry.", (
    Key("spall_strength", "quantity", "Spall: a cell whose maximum principal tensile stress "
        "exceeds this is damaged (> 0); with spall_time, the threshold sigma_0 of the "
        "Tuler-Butcher integral.", None, dim="pressure"),
    Key("spall_time", "quantity", "Tuler-Butcher spall (impulse form, lambda = 1): a cell is "
        "damaged once the integral of (sigma_1 / spall_strength - 1) dt over the time its "
        "maximum principal stress sigma_1 exceeds spall_strength reaches this (> 0); read under "
        "[fracture] spall_criterion = \"tuler-butcher\" (the default). Absent: the "
        "instantaneous threshold of [D19].", None, dim="time"),
    Key("loosening", "number", "Loosening chi*: a damaged cell with 1 - V0/V > chi* is fully "
        "fractured, in (0, 1); needs spall_strength.", None),
    Key("erosion", "choice", "Erosion criterion: elements meeting it are deleted.", None,
        choices=EROSION_CRITERIA),
    Key("erosion_value", "number", "Threshold of the erosion criterion (> 0).", COMPUTED,
        default_doc="1.0 for jc-damage, none for fractured, else required"),
    Key("jc_damage", "number-list", "Johnson-Cook fracture constants D1..D5; needed by "
        "erosion = \"jc-damage\".", None, length=5),
    Key("fracture_strain", "number", "Node separation [Z] (> 0): the bodies of this material are "
        "split into tied node copies that come apart where the plastic strain of the adjoining "
        "elements reaches this value ([fracture] separation_measure, separation_release).",
        None),
), shorthands=("none",), default="no failure")

MATERIAL = Table("material", "A material. Start from a library entry with `library` and "
                 "override any key, or give everything. Elastic constants: any two of "
                 "youngs_modulus, poisson_ratio, shear_modulus, bulk_modulus; or shear_modulus "
                 "alone with eos.c0 (K = rho c0^2). Keys given in the case replace the library's "
                 "(elastic constants as a set; strength and eos key by key unless the model "
                 "changes).", (
    Key("name", "string", "Name bodies refer to.", COMPUTED, default_doc="the library name"),
    Key("library", "string", "Library entry to start from (see impactsim.materials.library).",
        None),
    Key("density", "quantity", "Reference density rho0 (> 0).", dim="density"),
    Key("youngs_modulus", "quantity", "Young's modulus E (> 0).", None, dim="pressure"),
    Key("poisson_ratio", "number", "Poisson's ratio, in (-1, 0.5).", None),
    Key("shear_modulus", "quantity", "Shear modulus G (> 0).", None, dim="pressure"),
    Key("bulk_modulus", "quantity", "Bulk modulus K (> 0).", None, dim="pressure"),
    Key("specific_heat", "quantity", "Specific heat c_v for adiabatic heating (> 0).",
        _d(schema.Material, "specific_heat"), dim="specific_heat"),
    Key("taylor_quinney", "number", "Share of plastic work that heats, in [0, 1].",
        _d(schema.Material, "taylor_quinney")),
    Key("initial_temperature", "quantity", "Initial temperature (> 0 K).",
        _d(schema.Material, "initial_temperature"), dim="temperature"),
    Key("source", "string", "Where the numbers come from.", "",
        default_doc="the library entry's source"),
    Key("conductivity", "quantity", "Thermal conductivity k (> 0); quasistatic analysis.",
        None, dim="conductivity"),
    Key("conductivity_table", "string-list", "k(T) as a table: [\"T1 k1\", ...] with T in K "
        "and k in W/(m K), e.g. [\"300 7.6\", \"1000 3.3\"] (linear in between, constant "
        "outside); quasistatic analysis.", None),
    Key("expansion", "quantity", "Linear thermal expansion coefficient alpha; quasistatic "
        "analysis.", None, dim="expansion"),
    STRENGTH,
    EOS,
    FAILURE,
), array=True)

BOX = Table("box", "Nodes with lo <= x <= hi componentwise.", (
    Key("lo", "vector", "Lower corner.", dim="length"),
    Key("hi", "vector", "Upper corner.", dim="length"),
), default="none (off)")

PLANE = Table("plane", "Nodes within `tolerance` of a plane.", (
    Key("point", "vector", "A point of the plane.", dim="length"),
    Key("normal", "vector", "Plane normal (nonzero; normalised on load).", dim="dimensionless"),
), default="none (off)")

NODES = Table("nodes", "Node set of the body in world coordinates after placement: the string "
              "\"all\", or a table with exactly one of `box`, `outside_radius`, `plane`.", (
    BOX,
    Key("outside_radius", "quantity", "Nodes farther than this from the line through `center` "
        "along `axis` (the rim of a round plate).", None, dim="length"),
    Key("center", "vector", "A point of the axis (with outside_radius).", COMPUTED,
        dim="length", default_doc="the body's position"),
    Key("axis", "vector", "Axis direction (with outside_radius).", (0.0, 0.0, 1.0),
        dim="dimensionless"),
    PLANE,
    Key("tolerance", "quantity", "Distance from the plane (with plane).", COMPUTED,
        dim="length", default_doc="0.01 x mesh_size (1 um without one)"),
), shorthands=("all",), default="**required**")

CONSTRAINT = Table("constraint", "Prescribed velocity on a node set of the body.", (
    NODES,
    Key("velocity", "velocity-or-free", "Prescribed velocity; a component may be \"free\".",
        COMPUTED, default_doc="required unless fixed = true"),
    Key("fixed", "bool", "Shorthand for velocity = [0, 0, 0].", False),
), array=True)

BODY = Table("body", "A body: a meshed primitive (or a mesh file) of one material, placed, "
             "moving. Shape keys: box, plate: size = [lx, ly, lz]; cylinder: radius or diameter, "
             "height or length, axis; sphere: radius or diameter; file: path, scale; cube12 (the "
             "12-tet cube): size (edge length). The initial velocity is `velocity`, or `speed` "
             "with `direction` (optionally tilted by `obliquity` about `obliquity_axis`).", (
    Key("name", "string", "Name of the body.", COMPUTED, default_doc="`body<index>`"),
    Key("material", "string", "A [[material]] name, or directly a library name."),
    Key("shape", "choice", "Primitive.", choices=SHAPES),
    Key("size", "length-or-vector", "box, plate: [lx, ly, lz]; cube12: edge length.",
        default_doc="required (box, plate, cube12)", dim="length"),
    Key("radius", "quantity", "cylinder, sphere: radius (or give diameter).", REQUIRED,
        dim="length", default_doc="required (cylinder, sphere)"),
    Key("diameter", "quantity", "cylinder, sphere: diameter (or give radius).", None,
        dim="length"),
    Key("height", "quantity", "cylinder: height along the axis (or give length).", REQUIRED,
        dim="length", default_doc="required (cylinder)"),
    Key("length", "quantity", "cylinder: same as height.", None, dim="length"),
    Key("axis", "vector", "cylinder: axis direction (normalised on load).", (0.0, 0.0, 1.0),
        dim="dimensionless"),
    Key("path", "path", "file: mesh file (any meshio format), relative to the case file.",
        REQUIRED, default_doc="required (file)"),
    Key("scale", "number", "file: factor from file units to m (> 0).", 1.0),
    Key("position", "vector", "Centre of the primitive (of the mesh volume for file).",
        _d(schema.Body, "position"), dim="length"),
    Key("rotation", "vector", "Intrinsic x-y-z Euler angles, applied before translation.",
        _d(schema.Body, "rotation"), dim="angle"),
    Key("mesh_size", "quantity", "Target element edge length (> 0).", REQUIRED, dim="length",
        default_doc="required (not for cube12, file)"),
    Key("mesher", "choice", "Mesh generator; structured only for box, plate, cube12.",
        _d(schema.Body, "mesher"), choices=MESHERS),
    Key("element", "choice", "Element type of the body: tet (the formulation of run.element) "
        "or hex8, the one-point hexahedron with Flanagan-Belytschko hourglass control "
        "(box, plate: structured; cylinder: O-grid; sphere: cube-sphere; file: hexahedron "
        "cells).", _d(schema.Body, "element"), choices=BODY_ELEMENTS),
    Key("hourglass", "choice", "hex8: hourglass control form, viscous or stiffness "
        "(Flanagan & Belytschko 1981).", _d(schema.Body, "hourglass"), choices=HOURGLASS_FORMS),
    Key("hourglass_coefficient", "number", "hex8: hourglass coefficient (>= 0; 0 turns the "
        "control off).", COMPUTED, default_doc="0.1 viscous, 0.03 stiffness"),
    Key("velocity", "vector", "Initial velocity.", _d(schema.Body, "velocity"), dim="velocity"),
    Key("speed", "quantity", "Initial speed along `direction` (instead of velocity).", None,
        dim="velocity"),
    Key("direction", "vector", "Direction of `speed` (normalised on load).", None,
        dim="dimensionless", default_doc="required with speed"),
    Key("obliquity", "quantity", "Tilt of `direction` away from itself by this angle about "
        "`obliquity_axis` (with speed).", 0.0, dim="angle"),
    Key("obliquity_axis", "vector", "Axis of the obliquity rotation; only its part "
        "perpendicular to `direction` counts.", (0.0, 1.0, 0.0), dim="dimensionless"),
    Key("angular_velocity", "vector", "Initial angular velocity about `position`.",
        _d(schema.Body, "angular_velocity"), dim="angular_velocity"),
    CONSTRAINT,
), array=True)

WALL = Table("wall", "A rigid planar wall: the half space (x - point) . normal < 0 is "
             "forbidden.", (
    Key("point", "vector", "A point of the wall plane.", _d(schema.Wall, "point"), dim="length"),
    Key("normal", "vector", "Normal into the allowed side (nonzero; normalised on load).",
        _d(schema.Wall, "normal"), dim="dimensionless"),
    Key("friction", "number", "Coulomb friction coefficient (>= 0).",
        _d(schema.Wall, "friction")),
), array=True)

OUTPUT = Table("output", "What is written, and where.", (
    Key("directory", "path", "Output folder, relative to the working directory.", None,
        default_doc="`out/<run.name>`"),
    Key("frames", "int", "Evenly spaced frames after the initial one (>= 1); ignored when "
        "times is given.", _d(schema.Output, "frames")),
    Key("times", "quantity-list", "Explicit frame times (>= 0, increasing).", None, dim="time"),
    Key("history_every", "int", "Write a history.csv row every N steps (>= 1).",
        _d(schema.Output, "history_every")),
    Key("fields", "string-list", "Fields written to the frames.", None, default_doc="all"),
    Key("compression", "choice", "Compression of the frames' data: zlib (measured on a "
        "sphere-plate frame of 131k tets: 19 MB, 0.34 CPU s to write, zlib at level 1) or none "
        "(36 MB, 0.09 s).",
        _d(schema.Output, "compression"), choices=("zlib", "none")),
    Key("checkpoint_every", "steps-or-time", "Write a checkpoint of the whole state (into "
        "checkpoints/ of the output folder) every N steps (an integer) or every so much "
        "simulated time (\"0.5 us\"); `impactsim run CASE --resume DIR` continues from the last "
        "one. 0: none.", 0),
    Key("fragment_histogram", "bool", "Write fragments.png, the fragment-size histogram "
        "(number and mass of the fragments per mass bin) at the end of a run with fracture "
        "passes (summary.json fragments).", _d(schema.Output, "fragment_histogram")),
))

CONTACT = Table("contact", "Contact between bodies. Contact passes run only with two or more "
                "bodies, or with self_contact.", (
    Key("passes", "choice-list", "Contact passes, in the order they run each step.",
        tuple(_d(schema.Contact, "passes")), choices=CONTACT_PASSES),
    Key("friction", "number", "Coulomb friction coefficient (>= 0).",
        _d(schema.Contact, "friction")),
    Key("self_contact", "bool", "Contact of a body with itself (and contact passes with one "
        "body).", _d(schema.Contact, "self_contact")),
))

FRACTURE = Table("fracture", "How fractured material is represented.", (
    Key("particles_per_element", "int", "Particles replacing one fully fractured boundary "
        "cell (>= 1).", _d(schema.Fracture, "particles_per_element")),
    Key("particle_collisions", "bool", "Particles collide with each other, not only with "
        "surfaces.", _d(schema.Fracture, "particle_collisions")),
    Key("erosion_region", "choice", "Where erosion may delete elements: only at the contact "
        "surface [R20], or anywhere.", _d(schema.Fracture, "erosion_region"),
        choices=EROSION_REGIONS),
    Key("spall_criterion", "choice", "How spall reads the tension: tuler-butcher integrates "
        "it over time for materials with failure.spall_time (others spall at the threshold), "
        "instant is the threshold of [D19] for every material (docs/fracture.md).",
        _d(schema.Fracture, "spall_criterion"), choices=("tuler-butcher", "instant")),
    Key("spall_pressure", "choice", "The pressure the spall criterion reads: lesser, the "
        "smaller tension of the element's own pressure and its patch mean (a tension the cell "
        "and the cells around it carry: rejects the tet4 pressure checkerboard of a Taylor "
        "bar's foot); cell, the element's own (as [D19]; resolves a thin plate's spall layer "
        "but spalls checkerboard cells); patch, the mean over the patch of elements around its "
        "nodes (docs/fracture.md).",
        _d(schema.Fracture, "spall_pressure"), choices=("lesser", "cell", "patch")),
    Key("ductile_criterion", "choice", "Ductile fracture: johnson-cook accumulates the "
        "Johnson-Cook damage D (failure.jc_damage) of a material without an erosion criterion "
        "above the triaxiality -1/3, and a cell whose D reaches 1 is damaged as by spall "
        "(then loosens and leaves as particles); none: spall and loosening only "
        "(docs/fracture.md).", _d(schema.Fracture, "ductile_criterion"),
        choices=("johnson-cook", "none")),
    Key("distortion_interval", "quantity", "Distortion erosion [Z]: every this long (longer "
        "than the step) an element is deleted when an axis extent exceeds distortion_extent "
        "times its initial largest extent, the product of its axis extents exceeds "
        "distortion_volume times the initial one, or a corner's edge Jacobian changes sign "
        "(> 0; any body, any fracture method).", None, dim="time",
        default_doc="off"),
    Key("distortion_extent", "number", "r1 of distortion erosion (> 1).",
        _d(schema.Fracture, "distortion_extent")),
    Key("distortion_volume", "number", "r2 of distortion erosion (> 1).",
        _d(schema.Fracture, "distortion_volume")),
    Key("separation_measure", "choice", "Node separation: the plastic strain compared with "
        "failure.fracture_strain, the mean or the max of the elements adjoining a face (or, "
        "with separation_release = \"nodes\", a node).", _d(schema.Fracture,
                                                             "separation_measure"),
        choices=SEPARATION_MEASURES),
    Key("separation_release", "choice", "Node separation: \"faces\" splits a node family "
        "only along the faces that failed (partial release), \"nodes\" releases every copy of "
        "a node at once.", _d(schema.Fracture, "separation_release"),
        choices=SEPARATION_RELEASES),
))

CHECK_ACTIONS = ("error", "warn", "ignore")
CHECKS = Table("checks", "Conditions watched before and during a run, each with its action "
               "(LS-DYNA style): `error` stops the run (exit 3; before the first step, exit 2), "
               "`warn` prints it once with its count, `ignore` only records it in summary.json; "
               "`erode` removes the element at fault and goes on. Every triggered check is "
               "printed once and listed under `checks` in summary.json.", (
    Key("initial_penetration", "choice", "A body starting inside another body or a rigid wall "
        "(checked by `impactsim check` and at run start; the depth and the bodies are named).",
        _d(schema.Checks, "initial_penetration"), choices=CHECK_ACTIONS),
    Key("negative_volume", "choice", "An element turned inside out: stop, or erode it (its "
        "mass stays on its nodes, its energy goes to eroded_energy) and go on.",
        _d(schema.Checks, "negative_volume"), choices=("error", "erode")),
    Key("time_step_floor", "quantity", "Smallest accepted time step; 0 = off (run.dt_collapse "
        "still applies).", _d(schema.Checks, "time_step_floor"), dim="time"),
    Key("time_step_floor_action", "choice", "Below the floor: stop, or erode the element that "
        "sets the step and go on.", _d(schema.Checks, "time_step_floor_action"),
        choices=("error", "erode")),
    Key("energy_balance", "number", "Largest accepted gain of the total energy, as a share of "
        "the reference energy (the largest of |E0| and kinetic + internal so far), watched "
        "every step (> 0).", _d(schema.Checks, "energy_balance")),
    Key("energy_balance_action", "choice", "When the gain exceeds energy_balance.",
        _d(schema.Checks, "energy_balance_action"), choices=CHECK_ACTIONS),
    Key("hourglass_share", "number", "Largest accepted hourglass energy / (kinetic + "
        "internal); watched when the run has an hourglass_energy history column (hexahedra).",
        _d(schema.Checks, "hourglass_share")),
    Key("hourglass_share_action", "choice", "When the share exceeds hourglass_share.",
        _d(schema.Checks, "hourglass_share_action"), choices=CHECK_ACTIONS),
    Key("unconverged_contact", "choice", "Steps whose projected contact rounds did not converge "
        "(summary.json contact.node-face.unconverged_steps), more than "
        "unconverged_contact_share of the steps in contact.",
        _d(schema.Checks, "unconverged_contact"), choices=CHECK_ACTIONS),
    Key("unconverged_contact_share", "number", "Largest accepted share of the steps in "
        "contact whose projected rounds did not converge (0 acts on any; the bundled scenes "
        "have 0.5-11 %).", _d(schema.Checks, "unconverged_contact_share")),
))

ROOT = Table("", "The case file.", (RUN, MATERIAL, BODY, WALL, OUTPUT, CONTACT, FRACTURE,
                                    CHECKS))
