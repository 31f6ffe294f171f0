"""The studies of `make accuracy` (benchmarks/accuracy.py): which case, which overrides, which
levels, what is measured.

A study runs one or more series (element formulations, contact pass lists) over levels ordered
from the coarsest (cheapest) to the finest; each run is the study's case loaded with the study's,
the series' and the level's `--set` overrides (impactsim.case.load_case(path, overrides=...)).
``x`` is the level's mesh size [m] or Courant number; orders are fitted against it.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

# every run: one numba thread (two runs share the two cores), frames only at the start and end
COMMON = ["run.threads=1", "output.frames=1"]
# the bar held at its sides: uniaxial strain, so the 1-D wave solution is exact for the 3-D model
COLUMN = ['body.0.constraint=[{nodes = "all", velocity = [0, 0, "free"]}]']
TWO_COLUMNS = [k.replace("body.0", f"body.{i}") for i in (0, 1) for k in COLUMN]
TETS = {"tet4": ['run.element="tet4"'], "anp": ['run.element="anp"']}
# the one-point hex (solver/hex8.py) beside the tets: the bar with the default viscous control,
# the Taylor bar with the stiffness form (large plastic flow)
HEX = {"hex8": ['body.0.element="hex8"']}
HEX_TAYLOR = {"hex8": ['body.0.element="hex8"', 'body.0.hourglass="stiffness"']}
PASSES = {"node-face": ['contact.passes=["node-face"]'],
          "node-face + edge-edge": ['contact.passes=["node-face", "edge-edge"]']}


@dataclass
class Level:
    x: float  # mesh size [m] or Courant number
    overrides: list[str]
    label: str
    only: tuple[str, ...] = ()  # run for these series only (empty: every series)


@dataclass
class Study:
    key: str
    title: str
    case: Path
    measure: str  # a key of accuracy_measure.MEASURES
    about: str  # markdown paragraph: the problem, the reference, what to read in the results
    series: dict[str, list[str]]  # name -> overrides
    levels: list[Level]  # coarse to fine
    overrides: list[str] = field(default_factory=list)
    x_name: str = "h"  # "h" (mesh size, reported in mm) or "CFL"
    vs_finest: bool = False  # errors also against the finest run where an exact value exists


def _mm(h: float) -> str:
    return f"{h * 1e3:.4g} mm"


def mesh_levels(sizes_m: list[float], keys: list[str], column: float | None = None) -> list[Level]:
    """Levels setting the mesh size `keys` (body.N.mesh_size) to each size; with `column` the
    body is also made one cell wide (size [h, h, column])."""
    out = []
    for h in sizes_m:
        ov = [f"{k}={h!r}" for k in keys]
        if column is not None:
            ov.append(f"body.0.size=[{h!r}, {h!r}, {column!r}]")
        out.append(Level(h, ov, _mm(h)))
    return out


def cfl_levels(cfls: list[float]) -> list[Level]:
    return [Level(c, [f"run.cfl={c!r}"], f"CFL {c:g}") for c in cfls]


BAR = ROOT / "cases" / "elastic-bar-wall.toml"
TAYLOR = ROOT / "cases" / "taylor-bar.toml"
ELASTIC_BARS = ROOT / "cases" / "elastic-bars.toml"
CYLINDERS = ROOT / "cases" / "two-cylinders.toml"
# elastic-bars.toml with bars of 25 mm instead of 100 mm: a quarter of the cost, same physics
SHORT_BARS = ["run.end_time=16e-6",
              "body.striker.size=[0.01, 0.01, 0.025]", "body.striker.position=[0, 0, -0.012501]",
              "body.target.size=[0.01, 0.01, 0.025]", "body.target.position=[0, 0, 0.0125]"]


def studies() -> list[Study]:
    column_h = [5e-3 / 2 ** k for k in range(5)]  # 5 mm ... 0.3125 mm, 20 to 320 cells long
    bar_h = [10e-3 / n for n in (2, 3, 4, 6, 8)]  # 5 ... 1.25 mm: 2 to 8 cells across
    # 1.27 ... 0.635 mm for both formulations, elements doubling from level to level (2,700 to
    # 19,000), and 0.504 mm (37,000 elements) for tet4 alone: anp takes 1.8 times the steps
    # of tet4 (11,400 at 0.504 mm), which would add 11 minutes on a busy two-core machine.
    # Below 1.27 mm (six elements across) the results scatter more than they converge.
    taylor_h = [1.6e-3 * 2.0 ** (-k / 3) for k in range(1, 6)]
    taylor_levels = mesh_levels(taylor_h, ["body.0.mesh_size"])
    taylor_levels[-1].only = ("tet4", "hex8")
    taylor_cfl_h = taylor_h[0]
    cfls = [0.9, 0.6, 0.45, 0.3, 0.15]
    return [
        Study(
            "bar-column", "Elastic bar on a rigid wall, uniaxial strain (analytic)", BAR,
            "bar_column",
            "The bundled `cases/elastic-bar-wall.toml` (steel, 100 mm long, 20 m/s) with every "
            "node held in x and y and the bar one cell wide: uniaxial strain, where the 1-D "
            "wave solution is exact for the 3-D model. Analytic: contact stress rho c_L v, "
            "duration 2L/c_L, rebound at v, c_L = sqrt((K + 4G/3)/rho). `pulse_L1` is the L1 "
            "distance of the wall-force history from the analytic square pulse relative to its "
            "impulse. The stress plateau (median over the contact) is converged at every level: "
            "what is left is the linear theory's neglect of finite strain, of order v/c_L.",
            {**TETS, **HEX}, mesh_levels(column_h, ["body.0.mesh_size"], column=0.1),
            COMMON + COLUMN),
        Study(
            "bar-free", "Elastic bar on a rigid wall, free sides (3-D)", BAR, "bar_free",
            "The bundled `cases/elastic-bar-wall.toml` as it is (10 x 10 x 100 mm, 2 to 8 cells "
            "across). A bar free at its sides is not the 1-D bar: lateral inertia (Pochhammer-"
            "Chree dispersion) moves the converged stress plateau and duration about 1 % from "
            "rho c v and 2L/c (column '1-D theory' of the orders table: the finest run's "
            "deviation from it). The errors are therefore against the finest run.",
            {**TETS, **HEX}, mesh_levels(bar_h, ["body.0.mesh_size"]), COMMON),
        Study(
            "bar-cfl", "Elastic column: Courant number", BAR, "bar_column",
            "The uniaxial-strain column of the first study at h = 0.3125 mm, tet4, with Courant "
            "numbers from 0.9 to 0.15. 'vs exact' is the total error; 'vs finest' is the "
            "time-discretisation error alone (against the run at CFL 0.15), whose order is "
            "fitted against the CFL number (the time step is proportional to it; central "
            "differences are second order in it). Where the spatial error dominates the total "
            "does not fall with a smaller CFL number: lumped-mass central differences are least "
            "dispersive near the stability limit, so a smaller step only costs.",
            {"tet4": TETS["tet4"]}, cfl_levels(cfls),
            COMMON + COLUMN + mesh_levels([column_h[-1]], ["body.0.mesh_size"],
                                          column=0.1)[0].overrides,
            x_name="CFL", vs_finest=True),
        Study(
            "taylor-mesh", "Taylor bar: mesh size and element formulation", TAYLOR,
            "taylor_bar",
            "The bundled `cases/taylor-bar.toml` (OFHC copper, Johnson-Cook, 190 m/s, 80 us) at "
            "gmsh mesh sizes from 1.27 to 0.635 mm (the case's own is 0.8 mm; the elements "
            "double from level to level) with the constant-strain tet (`tet4`) and the "
            "averaged nodal-pressure tet (`anp`), and at 0.504 mm with tet4 alone (anp takes "
            "about twice the steps, and the run would double the study's time). Final length "
            "and foot diameter in the last frame, against the finest run of the same "
            "formulation; the two formulations converge to different shapes (tet4 locks in "
            "near-incompressible flow and keeps the foot narrow), so compare their values, not "
            "only their errors. Each level is a new unstructured mesh, which adds a scatter of "
            "a few tenths of a percent to the length. The measured final length of Johnson & "
            "Cook (1983) is about 16.2 mm. `hex8` is the one-point hex (O-grid mesh, "
            "stiffness hourglass control), which does not lock: compare it with anp.",
            {**TETS, **HEX_TAYLOR}, taylor_levels,
            COMMON + ["output.history_every=100"]),
        Study(
            "taylor-cfl", "Taylor bar: Courant number", TAYLOR, "taylor_bar",
            f"The Taylor bar at h = {taylor_cfl_h * 1e3:.3g} mm, tet4, with Courant numbers from "
            "0.9 to 0.15: the time-discretisation error against the run at CFL 0.15.",
            {"tet4": TETS["tet4"]}, cfl_levels(cfls),
            COMMON + ["output.history_every=100", f"body.0.mesh_size={taylor_cfl_h!r}"],
            x_name="CFL"),
        Study(
            "contact-passes", "Contact passes: node-face alone or with edge-edge", CYLINDERS,
            "two_cylinders",
            "The bundled `cases/two-cylinders.toml` [D19]: an aluminium striker 10 mm across "
            "hits a target 20 mm across at 1 km/s and spreads over its face, where edges of the "
            "two surfaces cross; both bodies at the mesh size h (the case's own is 1 mm; the "
            "finest level here is 1.41 mm, for cost). The exact solution has no penetration: "
            "`penetration` is the largest over the run (history.csv max_penetration, every 5th "
            "step), in um. The striker's length along the axis and its mean axial speed at "
            "12 us are against the finest run of the same pass list. With both passes the "
            "striker's speed is within 2 % of the finest run's at every level, so its 'error' "
            "is the scatter of the contact's release, not a discretisation error that "
            "refinement reduces.",
            PASSES, mesh_levels([2e-3 * 2 ** (-k / 2) for k in range(-2, 2)],
                                ["body.0.mesh_size", "body.1.mesh_size"]),
            ["run.threads=1", 'output.times=["12 us"]', "output.history_every=5"]),
        Study(
            "contact-column", "Contact passes, uniaxial strain (analytic)", ELASTIC_BARS,
            "two_bars_column",
            "The bundled `cases/elastic-bars.toml` (two identical steel bars end-on, 20 m/s) "
            "with bars 25 mm long instead of 100 mm (cost), the target meshed with one cell more "
            "across than the striker so that the meshes do not match at the interface (h below "
            "is the striker's), and every node held in x and y: uniaxial strain, where the 1-D "
            "solution is exact: interface stress rho c_L v / 2 for 2L/c_L, then the striker at "
            "rest (`striker_speed`, its final mean speed in m/s, is the error of the momentum "
            "handed over). The contact impulses leave the held x and y components alone "
            "(docs/physics.md), so no node slips past the other body's faces with either pass "
            "list. The stress is the sum of the contact impulses over the middle half "
            "of the contact, over that time and the cross-section: it tells whether the contact "
            "carries the analytic stress (its error falls from about 3 % at 2 cells across to "
            "0.5 % at 8). The contact duration is not "
            "measured here: the last step with contact pairs lags the analytic release by 1-2 % "
            "at every level, as the bars part over a few steps.",
            PASSES, _two_bar_levels([2, 3, 4, 6, 8]), COMMON + SHORT_BARS + TWO_COLUMNS),
    ]


def _two_bar_levels(cells: list[int]) -> list[Level]:
    out = []
    for n in cells:
        hs, ht = 10e-3 / n, 10e-3 / (n + 1)
        out.append(Level(hs, [f"body.striker.mesh_size={hs!r}", f"body.target.mesh_size={ht!r}"],
                         f"{n}/{n + 1} cells across"))
    return out
