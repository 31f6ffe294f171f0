"""Quasistatic case files (``[run] analysis = "quasistatic"``) -> a validated ``QSCase``.

Same reading machinery and error style as the dynamic cases (``file: key.path: message``,
``CaseError``): the key table is ``quasistatic_spec.QS_ROOT``, materials are read by the dynamic
reader (library merge, elastic constants) plus their thermal keys. Meshing and the selection of
facets happen later (``impactsim.quasistatic.build``).
"""

from __future__ import annotations

import tomllib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Sequence

from impactsim.case.errors import CaseError, KeyPath
from impactsim.case.load import _materials, _resolve_material, _syntax_message, _unique
from impactsim.case.overrides import apply_overrides
from impactsim.case.quasistatic_spec import CONDITION_KEYS, QS_ROOT, QS_SHAPE_KEYS
from impactsim.case.read import Reader, non_negative, positive
from impactsim.case.units import parse_quantity


@dataclass
class QSMaterial:
    name: str
    density: float
    youngs_modulus: float
    poisson_ratio: float
    specific_heat: float
    initial_temperature: float
    conductivity: float | None
    conductivity_table: tuple[tuple[float, ...], tuple[float, ...]] | None
    expansion: float
    source: str


@dataclass
class QSBoundary:
    name: str
    where: str  # key path, for messages
    region: str  # plane | box | group
    params: dict
    tolerance: float
    conditions: dict  # condition key -> value (SI); ambient with exchange
    ramp: bool


@dataclass
class QSBody:
    name: str
    where: str
    material: str
    shape: str
    dims: dict
    position: tuple
    rotation: tuple
    mesh_size: float
    mesher: str
    initial_temperature: float
    heat_source: float
    copies: tuple[int, tuple] | None
    refine: dict | None
    clip: tuple | None
    boundaries: list[QSBoundary] = field(default_factory=list)
    centering_axis: tuple | None = None


@dataclass
class QSPair:
    bodies: tuple[str, str]
    friction: float
    conductance: float
    gap_tolerance: float | None
    tied: bool = False
    robin: float = 0.0


@dataclass
class QSCase:
    source: Path | None
    name: str
    end_time: float
    times: list[float]
    settings: dict
    materials: dict[str, QSMaterial]
    bodies: list[QSBody]
    detect: bool
    gap_tolerance: float
    pairs: list[QSPair]
    directory: Path | None
    raw: dict


def is_quasistatic(path: Path | str, overrides: Sequence[str] = ()) -> bool:
    """Whether the case file asks for the quasistatic analysis (False if it cannot be read:
    the dynamic loader then reports the problem)."""
    try:
        raw = tomllib.loads(Path(path).read_text(encoding="utf-8"))
        apply_overrides(raw, [o for o in overrides if o.startswith("run.analysis")])
    except Exception:  # any unreadable file: left to the dynamic loader's messages
        return False
    run = raw.get("run")
    return isinstance(run, dict) and run.get("analysis") == "quasistatic"


def load_quasistatic(path: Path | str, overrides: Sequence[str] = ()) -> QSCase:
    path = Path(path)
    try:
        raw = tomllib.loads(path.read_text(encoding="utf-8"))
    except tomllib.TOMLDecodeError as err:
        raise CaseError(f"{path}: {_syntax_message(err)}") from None
    except OSError as err:
        raise CaseError(f"{path}: cannot read: {err}") from None
    return quasistatic_from_dict(raw, path, overrides)


def quasistatic_from_dict(raw: dict, source: Path | None = None,
                          overrides: Sequence[str] = ()) -> QSCase:
    label = str(source) if source is not None else "<string>"
    try:
        apply_overrides(raw, overrides, QS_ROOT)
        return _build(raw, source)
    except CaseError as err:
        raise CaseError(f"{label}: {err}") from None


def _build(raw: dict, source: Path | None) -> QSCase:
    import copy

    raw_copy = copy.deepcopy(raw)
    top = Reader(raw, QS_ROOT, KeyPath())
    base = source.parent if source is not None else Path.cwd()
    run = top.sub("run")
    name = run.get("name") if run.has("name") else (source.stem if source else "case")
    end = positive(run.require("end_time", " (e.g. end_time = \"1 s\")"), run.at("end_time"))
    times = run.get("times")
    if times is not None:
        if run.has("steps"):
            raise run.error("steps", "give steps or times, not both")
        if not times:
            raise run.error("times", "must list at least one time")
        for i, t in enumerate(times):
            if t <= (times[i - 1] if i else 0.0):
                raise run.at(f"times[{i}]").error("times must be > 0 and increase")
        if abs(times[-1] - end) > 1e-12 * end:
            raise run.at("times").error(f"the last time ({times[-1]:g} s) must be end_time "
                                        f"({end:g} s)")
    else:
        n = int(positive(run.get("steps"), run.at("steps")))
        times = [end * (k + 1) / n for k in range(n)]
    q = top.sub("quasistatic")
    settings = {k.name: q.get(k.name) for k in q.table.keys}
    for k in ("gap_tolerance", "pressure_tolerance", "heat_tolerance", "relaxation"):
        positive(settings[k], q.at(k))
    non_negative(settings["regularization"], q.at("regularization"))
    for k in ("max_iterations", "max_heat_iterations", "direct_limit"):
        positive(settings[k], q.at(k))
    if settings["relaxation"] >= 2:
        raise q.error("relaxation", f"must be in (0, 2), got {settings['relaxation']:g}")
    dyn = _materials(top)
    bodies = []
    for i, (rb, where) in enumerate(top.items("body")):
        bodies.append(_body(rb, where, i, base, dyn))
    if not bodies:
        raise KeyPath(("body",)).error("the case has no bodies: add a [[body]] table")
    _unique([b.name for b in bodies], "body")
    mats = {}
    raw_mats = {m.get("name", m.get("library")): m for m in raw.get("material", [])
                if isinstance(m, dict)}
    for b in bodies:
        if b.material not in mats:
            mats[b.material] = _thermal(dyn[b.material], raw_mats.get(b.material))
        if b.initial_temperature is None:
            b.initial_temperature = mats[b.material].initial_temperature
    c = top.sub("contact")
    sizes = [b.mesh_size for b in bodies if b.mesh_size]
    gap_tol = c.get("gap_tolerance")
    if gap_tol is None or gap_tol is COMPUTED_SENTINEL:
        gap_tol = 0.01 * min(sizes) if sizes else 1e-6
    pairs = []
    for j, (rp, wp) in enumerate(c.items("pair")):
        r = Reader(rp, QS_ROOT.get("contact").get("pair"), wp)
        bs = r.require("bodies")
        if len(bs) != 2:
            raise r.error("bodies", f"expected two names or patterns, got {len(bs)}")
        import fnmatch
        for k, pat in enumerate(bs):
            if not any(fnmatch.fnmatchcase(n, pat) for n in _all_names(bodies)):
                raise r.at(f"bodies[{k}]").error(f"'{pat}' matches no body")
        raw = rp.get("friction")
        if raw == float("inf") or (isinstance(raw, str) and raw.strip().lower() == "inf"):
            fr = float("inf")  # stuck: every node in contact keeps its tangential position
        else:
            fr = non_negative(r.get("friction"), r.at("friction"))
        gt = r.get("gap_tolerance")
        pairs.append(QSPair(tuple(bs), fr, non_negative(r.get("conductance"),
                                                        r.at("conductance")),
                            None if gt is COMPUTED_SENTINEL else gt, r.get("tied"),
                            non_negative(r.get("robin"), r.at("robin"))))
        if pairs[-1].robin > 0 and fr > 0:
            raise r.error("robin", "Robin conditions are for frictionless pairs (friction 0)")
    detect = c.get("detect")
    if not detect and not pairs:
        raise c.error("detect", "detect = false needs [[contact.pair]] entries")
    out = top.sub("output")
    directory = out.get("directory")
    return QSCase(source, name, end, list(times), settings, mats, bodies, detect,
                  positive(gap_tol, c.at("gap_tolerance")), pairs, directory, raw_copy)


from impactsim.case.spec import COMPUTED as COMPUTED_SENTINEL  # noqa: E402


def _all_names(bodies: list[QSBody]) -> list[str]:
    out = []
    for b in bodies:
        if b.copies:
            out += [f"{b.name}{k + 1}" for k in range(b.copies[0])]
        else:
            out.append(b.name)
    return out


def _thermal(m, raw: dict | None) -> QSMaterial:
    """The thermal keys of a material (its own table merged with the library entry)."""
    from impactsim.materials import library
    from impactsim.case.spec import MATERIAL

    merged: dict = {}
    lib = (raw or {}).get("library") or (m.name if library.canonical(m.name) else None)
    if lib and library.canonical(lib):
        merged.update(library.get(library.canonical(lib)))
    merged.update({k: v for k, v in (raw or {}).items() if k != "library"})
    where = KeyPath(("material",), f'material "{m.name}"')
    r = Reader({k: v for k, v in merged.items() if MATERIAL.get(k) is not None}, MATERIAL,
               where)
    g, k = m.shear_modulus, m.bulk_modulus
    e = 9 * k * g / (3 * k + g)
    nu = (3 * k - 2 * g) / (2 * (3 * k + g))
    table = None
    if r.has("conductivity_table"):
        rows = r.get("conductivity_table")
        ts, ks = [], []
        for i, row in enumerate(rows):
            parts = row.split()
            p = r.at(f"conductivity_table[{i}]")
            if len(parts) != 2:
                raise p.error(f"expected \"<T in K> <k in W/(m K)>\", got {row!r}")
            ts.append(parse_quantity(parts[0], "dimensionless", str(p)))
            ks.append(positive(parse_quantity(parts[1], "dimensionless", str(p)), p))
            if i and ts[-1] <= ts[-2]:
                raise p.error("temperatures must increase")
        table = (tuple(ts), tuple(ks))
    cond = r.get("conductivity")
    if cond is not None:
        positive(cond, r.at("conductivity"))
    return QSMaterial(m.name, m.density, e, nu, m.specific_heat, m.initial_temperature, cond,
                      table, r.get("expansion") or 0.0, m.source)


def _body(raw: dict, path: KeyPath, index: int, base: Path, materials: dict) -> QSBody:
    from impactsim.case.quasistatic_spec import QS_BODY

    name = raw.get("name", f"body{index}")
    r = Reader(raw, QS_BODY, path.labelled(f'body "{name}"'))
    shape = r.get("shape")
    for key in {k for ks in QS_SHAPE_KEYS.values() for k in ks} - set(QS_SHAPE_KEYS[shape]):
        if r.has(key):
            raise r.error(key, f"key '{key}' does not apply to shape '{shape}' (its keys: "
                               f"{', '.join(QS_SHAPE_KEYS[shape])})")
    dims: dict = {}
    if shape == "box":
        dims["size"] = tuple(positive(v, r.at("size")) for v in r.get("size"))
    if shape in ("cylinder", "tube", "sphere"):
        if r.has("diameter"):
            if r.has("radius"):
                raise r.error("diameter", "give radius or diameter, not both")
            dims["radius"] = positive(r.get("diameter"), r.at("diameter")) / 2
        else:
            dims["radius"] = positive(r.require("radius", f" (or diameter) for shape "
                                                          f"'{shape}'"), r.at("radius"))
    if shape in ("cylinder", "tube"):
        dims["height"] = positive(r.require("height", f" for shape '{shape}'"), r.at("height"))
    if shape == "tube":
        ri = positive(r.require("inner_radius", " for shape 'tube'"), r.at("inner_radius"))
        if ri >= dims["radius"]:
            raise r.error("inner_radius", f"must be below the radius ({dims['radius']:g} m)")
        dims["inner_radius"] = ri
    if shape == "file":
        p = r.require("path", " for shape 'file'")
        p = p if p.is_absolute() else base / p
        if not p.exists():
            raise r.error("path", f"mesh file not found: {p}")
        dims["path"] = p
        dims["scale"] = positive(r.get("scale"), r.at("scale"))
    mesh_size = 0.0
    if shape != "file" or r.has("mesh_size"):
        mesh_size = positive(r.get("mesh_size"), r.at("mesh_size"))
    if r.get("mesher") == "structured" and shape != "box":
        raise r.error("mesher", f"mesher 'structured' meshes box only, not '{shape}'")
    material = _resolve_material(r.get("material"), materials, r.at("material"))
    copies = None
    if r.has("copies"):
        c = r.sub("copies")
        copies = (int(positive(c.get("count"), c.at("count"))), c.get("offset"))
    refine = None
    if r.has("refine"):
        f = r.sub("refine")
        refine = {"point": f.get("point"), "size": positive(f.get("size"), f.at("size")),
                  "radius": positive(f.get("radius"), f.at("radius"))}
    clip = None
    if r.has("clip"):
        c = r.sub("clip")
        clip = (c.get("lo"), c.get("hi"))
    t0 = r.get("initial_temperature")
    body = QSBody(name, str(path), material, shape, dims, r.get("position"), r.get("rotation"),
                  mesh_size, r.get("mesher"), None if t0 is COMPUTED_SENTINEL else t0,
                  non_negative(r.get("heat_source"), r.at("heat_source")), copies, refine, clip)
    axis = r.get("centering_axis")
    if axis is not None and not any(axis):
        raise r.error("centering_axis", "must be a nonzero vector")
    body.centering_axis = axis
    for j, (rb, wb) in enumerate(r.items("boundary")):
        body.boundaries.append(_boundary(rb, wb, j, body))
    _unique([b.name for b in body.boundaries], f"body[{index}].boundary")
    return body


def _boundary(raw: dict, path: KeyPath, index: int, body: QSBody) -> QSBoundary:
    from impactsim.case.quasistatic_spec import BOUNDARY

    r = Reader(raw, BOUNDARY, path.labelled(f'body "{body.name}"'))
    name = r.get("name") if r.has("name") else f"boundary{index}"
    regions = r.given(("plane", "box", "cylinder", "group"))
    if len(regions) != 1:
        raise r.error("plane", "give exactly one of plane, box, cylinder, group"
                      + (f" (got {', '.join(regions)})" if regions else ""))
    region = regions[0]
    params: dict = {}
    if region == "plane":
        p = r.sub("plane")
        params = {"point": p.get("point"), "normal": p.get("normal")}
        if not any(params["normal"]):
            raise p.error("normal", "must be a nonzero vector")
    elif region == "box":
        b = r.sub("box")
        params = {"lo": b.get("lo"), "hi": b.get("hi")}
    elif region == "cylinder":
        c = r.sub("cylinder")
        params = {"point": c.get("point"), "axis": c.get("axis"),
                  "radius": positive(c.get("radius"), c.at("radius"))}
        if not any(params["axis"]):
            raise c.error("axis", "must be a nonzero vector")
    else:
        if body.shape != "file":
            raise r.error("group", "physical groups exist only on mesh files (shape = \"file\")")
        params = {"group": r.get("group")}
    tol = r.get("tolerance")
    tol = 0.01 * (body.mesh_size or 1e-4) if tol is COMPUTED_SENTINEL else tol
    conditions = {k: r.get(k) for k in CONDITION_KEYS if r.has(k)}
    if not conditions:
        raise r.error("temperature", "no condition: give one of " + ", ".join(CONDITION_KEYS))
    if "temperature" in conditions and ("flux" in conditions or "exchange" in conditions):
        raise r.error("temperature", "a prescribed temperature excludes flux and exchange on "
                                     "the same part")
    if "exchange" in conditions:
        conditions["ambient"] = r.require("ambient", " with exchange")
        non_negative(conditions["exchange"], r.at("exchange"))
    elif r.has("ambient"):
        raise r.error("ambient", "ambient goes with exchange")
    if "temperature" in conditions:
        positive(conditions["temperature"], r.at("temperature"))
    if "displacement" in conditions and all(v is None for v in conditions["displacement"]):
        raise r.error("displacement", "all three components are free: nothing is prescribed")
    return QSBoundary(name, str(path), region, params, tol, conditions, r.get("ramp"))


def describe_quasistatic(case: QSCase) -> str:
    """What `impactsim check` prints for a quasistatic case: what would be solved."""
    from impactsim.case.units import format_quantity as fq

    s = case.settings
    anderson = f" + Anderson {s['anderson']}" if s["anderson"] else ""
    lines = [f"case {case.name}: quasistatic thermoelastic contact (Schwarz method [G15])",
             f"  load steps: {len(case.times)} up to {fq(case.end_time, 'time')}; heat "
             f"{s['heat']}; element {s['element']}",
             f"  Schwarz: relaxation {s['relaxation']:g}{' + Aitken' if s['aitken'] else ''}"
             f"{anderson}, "
             f"tolerances gap {s['gap_tolerance']:g} pressure {s['pressure_tolerance']:g}, at "
             f"most {s['max_iterations']} iterations; workers {s['workers']}",
             f"  contact: {'detected' if case.detect else 'listed pairs only'}, gap tolerance "
             f"{fq(case.gap_tolerance, 'length')}"]
    for p in case.pairs:
        lines.append(f"    pair {p.bodies[0]} / {p.bodies[1]}: friction {p.friction:g}, "
                     f"conductance {p.conductance:g} W/(m^2 K)"
                     + (f", Robin alpha {p.robin:g} Pa/m" if p.robin else ""))
    lines.append("  materials:")
    for m in case.materials.values():
        k = (f"k(T) table {len(m.conductivity_table[0])} points" if m.conductivity_table
             else f"k {m.conductivity if m.conductivity is not None else 'not given (1)'} W/(m K)")
        lines.append(f"    {m.name}: E {fq(m.youngs_modulus, 'pressure')}, nu "
                     f"{m.poisson_ratio:.3g}, alpha {m.expansion:g} 1/K, {k}, rho "
                     f"{m.density:g} kg/m^3, c {m.specific_heat:g} J/(kg K)")
    lines.append("  bodies:")
    for b in case.bodies:
        dims = ", ".join(f"{k} {fq(v, 'length') if isinstance(v, float) else v}"
                         for k, v in b.dims.items())
        copies = f" x {b.copies[0]} copies" if b.copies else ""
        lines.append(f"    {b.name}{copies}: {b.shape} ({dims}), {b.material}, mesh size "
                     f"{fq(b.mesh_size, 'length')}, T0 {b.initial_temperature:g} K"
                     + (f", heat source {b.heat_source:g} W/m^3" if b.heat_source else ""))
        for bd in b.boundaries:
            conds = ", ".join(f"{k} {v}" for k, v in bd.conditions.items())
            lines.append(f"      {bd.name} ({bd.region}): {conds}")
    return "\n".join(lines)
