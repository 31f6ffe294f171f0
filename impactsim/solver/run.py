"""Run a case: mesh, build the state and the passes, integrate, write the outputs."""

from __future__ import annotations

import math
import platform
import time as wallclock
from pathlib import Path

import numpy as np

from impactsim.case.schema import Case
from impactsim.model import ERODED, Model
from impactsim.solver.build import build_model
from impactsim.solver.loop import Simulation, SimulationStopped
from impactsim.solver.pipeline import build_passes, mach_warnings

CORE_COLUMNS = ["time", "step", "dt", "kinetic_energy", "internal_energy", "viscous_energy",
                "contact_dissipated", "external_work", "eroded_energy", "total_energy",
                "momentum_x", "momentum_y", "momentum_z"]


class SimulationError(Exception):
    """A run that cannot start (bad mesh, inconsistent state): printed without a traceback."""


def frame_times(case: Case) -> np.ndarray:
    end = case.run.end_time
    if case.output.times is not None:
        t = np.array(sorted(set(float(v) for v in case.output.times if 0.0 <= v <= end)))
    else:
        n = case.output.frames
        t = end * np.arange(n + 1) / n  # exact end points, unlike linspace
    return t


def frame_fields(model: Model) -> tuple[dict, dict]:
    """Point and cell data of a frame (DESIGN.md Output)."""
    # the keys are impactsim.output.fields.FRAME_FIELDS
    point = {"velocity": model.v, "displacement": model.x - model.x0}
    cell = cell_fields(model)
    if model.blocks:  # the further blocks' cells follow the tets' (frame_cells)
        blocks = [cell_fields(b) for b in model.blocks]
        cell = {k: np.concatenate([v] + [b[k] for b in blocks]) for k, v in cell.items()}
    return point, cell


def cell_fields(src) -> dict:
    """The cell data of the elements of `src` (the Model's tets or an ElementBlock)."""
    from impactsim.output.series import voigt_to_tensor

    s = src.sdev
    sigma = s.copy()
    sigma[:, :3] -= src.pressure[:, None]
    vm = np.sqrt(1.5 * (np.sum(s[:, :3] ** 2, axis=1) + 2.0 * np.sum(s[:, 3:] ** 2, axis=1)))
    return {"stress": voigt_to_tensor(sigma), "pressure": src.pressure, "von_mises": vm,
            "plastic_strain": src.eps_p, "temperature": src.temperature,
            "status": src.status.astype(np.int32), "body": src.elem_body,
            "density": src.elem_mass / np.where(src.vol > 0, src.vol, np.inf),
            "internal_energy": src.energy}


def frame_cells(model: Model) -> tuple:
    """(cells, keep) of a frame: the tets, or the list of blocks (tets, hexes) with the mask of
    the live cells over their concatenation."""
    if not model.blocks:
        return model.conn, model.status != ERODED
    return ([model.conn] + [b.conn for b in model.blocks],
            np.concatenate([model.status] + [b.status for b in model.blocks]) != ERODED)


def body_summary(model: Model) -> dict:
    out = {}
    for b, name in enumerate(model.body_names):
        sl = slice(model.node_start[b], model.node_start[b + 1])
        m = float(model.mass[sl].sum())
        p = model.mass[sl] @ model.v[sl]
        out[name] = {"mass": m, "momentum": p.tolist(),
                     "mean_velocity": (p / m).tolist() if m > 0 else [0.0, 0.0, 0.0],
                     "nodes": int(sl.stop - sl.start),
                     "elements": int(model.elem_start[b + 1] - model.elem_start[b])
                     + sum(int(k.body_start[b + 1] - k.body_start[b]) for k in model.blocks)}
    return out


SMALL_MESH = 50_000  # elements; below this one thread beats two (launch and wait costs)


def thread_count(requested: int, n_elem: int) -> int:
    """Numba threads for a run: the case's run.threads, or when 0 one thread for small meshes
    (a parallel launch per kernel costs more than it gains there, above all on a busy machine)
    and every thread otherwise."""
    import numba

    if requested > 0:
        return min(requested, numba.config.NUMBA_NUM_THREADS)
    return 1 if n_elem < SMALL_MESH else numba.config.NUMBA_NUM_THREADS


def run_case(case: Case, out_dir: Path | None = None, progress: bool = True,
             meshes: list | None = None) -> dict:
    """Run `case`, writing series.pvd + frames, history.csv, summary.json and case.resolved.toml
    into out_dir (default out/<run name>). Returns the summary dict. A run that has to stop
    (inverted element, collapsing step, interrupt) still writes its last frame and summary."""
    import numba

    from impactsim.case import case_to_dict
    from impactsim.output.history import HistoryWriter
    from impactsim.output.progress import Progress
    from impactsim.output.series import SeriesWriter
    from impactsim.output.summary import write_resolved_case, write_summary

    start = wallclock.perf_counter()
    out = Path(out_dir) if out_dir is not None else (
        case.output.directory or Path("out") / case.run.name)
    out.mkdir(parents=True, exist_ok=True)
    bar = Progress(case.run.end_time, enabled=progress)
    timings: dict[str, float] = {}

    write_resolved_case(out / "case.resolved.toml", case_to_dict(case))
    t = wallclock.perf_counter()
    if meshes is None:
        from impactsim.mesh import mesh_body

        meshes = [mesh_body(b) for b in case.bodies]
    timings["meshing"] = wallclock.perf_counter() - t
    try:
        model = build_model(case, meshes)
    except ValueError as err:
        raise SimulationError(f"{case.run.name}: {err}") from err
    n_elem = model.n_elem + sum(b.n_elem for b in model.blocks)
    numba.set_num_threads(thread_count(case.run.threads, n_elem))
    if model.blocks:
        from impactsim.solver.blocks import unsupported

        why = unsupported(case)
        if why:
            raise SimulationError(f"{case.run.name}: {why}")
    passes = build_passes(case, model)
    bar.log(f"{case.run.name}: {model.n_node} nodes, {n_elem} elements, "
            f"{model.n_body} bodies; passes: " + (", ".join(p.name for p in passes) or "none"))
    for w in mach_warnings(case):
        bar.log("warning: " + w)
    sim = Simulation(model, passes, cfl=case.run.cfl, element=case.run.element,
                     cq=case.run.q_quadratic, cl=case.run.q_linear,
                     dt_collapse=case.run.dt_collapse)
    timings["setup"] = wallclock.perf_counter() - start - timings["meshing"]

    # frames are written by threads of their own while the run goes on (output/series.py)
    series = SeriesWriter(out, compression=case.output.compression, background=True)
    pass_series: dict[str, SeriesWriter] = {}  # the passes' own series (particles)
    fields = case.output.fields
    columns = CORE_COLUMNS + (["hourglass_energy"] if model.blocks else []) + [
        k for p in passes for k in p.history(model)]
    history = HistoryWriter(out / "history.csv", list(dict.fromkeys(columns)))
    times = frame_times(case)
    next_frame = 0
    end = case.run.end_time
    eps_t = 1e-9 * end
    e0 = None
    stopped = None
    first_step_seconds = None
    t_out = 0.0

    def write_frame():
        nonlocal t_out
        t1 = wallclock.perf_counter()
        point, cell = frame_fields(model)
        if fields is not None:
            point = {k: v for k, v in point.items() if k in fields}
            cell = {k: v for k, v in cell.items() if k in fields}
        cells, keep = frame_cells(model)
        series.write(model.time, model.x, cells, point, cell, keep=keep)
        for pa in passes:  # passes with series of their own (particles) write with every frame
            for key, (points, data) in (pa.frame(model) if hasattr(pa, "frame") else {}).items():
                if key not in pass_series:
                    pass_series[key] = SeriesWriter(out, prefix=key, pvd_name=f"{key}.pvd",
                                                    compression=case.output.compression,
                                                    background=True)
                pass_series[key].write(model.time, points, None, point_data=data)
        t_out += wallclock.perf_counter() - t1

    def history_row():
        nonlocal t_out
        t1 = wallclock.perf_counter()
        row = {"time": model.time, "step": model.step, "dt": sim.dt}
        row.update(sim.energies())
        row = {k: v for k, v in row.items() if k in history.columns}
        p = sim.momentum()
        row.update(momentum_x=p[0], momentum_y=p[1], momentum_z=p[2])
        for pa in passes:
            row.update(pa.history(model))
        history.row(row)
        t_out += wallclock.perf_counter() - t1
        return row

    try:
        e0 = history_row()["total_energy"]
        if times.size and times[0] <= eps_t:
            write_frame()
            next_frame = 1
        while model.time < end - eps_t:
            if model.step >= case.run.max_steps:
                stopped = f"max_steps = {case.run.max_steps} reached at t = {model.time:.6g} s"
                break
            target = times[next_frame] if next_frame < len(times) else end
            sim.step(target - model.time)
            if abs(model.time - target) <= eps_t:
                model.time = float(target)  # no round-off drift of frame times
            if first_step_seconds is None:
                first_step_seconds = wallclock.perf_counter() - start
            if model.step % case.output.history_every == 0:
                history_row()
            while next_frame < len(times) and model.time >= times[next_frame] - eps_t:
                write_frame()
                next_frame += 1
            bar.update(model.time, model.step, sim.dt)
    except SimulationStopped as err:
        stopped = str(err)
    except KeyboardInterrupt:
        stopped = f"interrupted at t = {model.time:.6g} s"
    finally:
        if stopped is not None:
            bar.log(f"stopped: {stopped}")
            try:
                history_row()
                write_frame()
            except Exception:  # the state may be non-finite; the frames so far stand
                pass
        history.close()
        bar.close()
        t1 = wallclock.perf_counter()
        for writer in (series, *pass_series.values()):
            writer.close()  # the frames still being written
        t_out += wallclock.perf_counter() - t1

    energies = sim.energies()
    wall = wallclock.perf_counter() - start
    timings.update({k: v for k, v in sim.timings.items()})
    timings["output"] = t_out
    summary = {
        "case": case.run.name,
        "source": str(case.source) if case.source else None,
        "nodes": model.n_node, "elements": n_elem, "bodies": body_summary(model),
        "steps": model.step, "time": model.time, "end_time": end,
        "wall_seconds": wall, "seconds_to_first_step": first_step_seconds,
        "seconds_per_pass": timings,
        "ns_per_element_step": (1e9 * sim.timings["element"] / (n_elem * model.step)
                                if model.step and n_elem else None),
        "passes": [p.name for p in passes],
        "energy": energies,
        "energy_balance_error": ((energies["total_energy"] - e0) / max(abs(e0), 1e-300)
                                 if e0 else 0.0),
        "stopped": stopped,
        "threads": numba.get_num_threads(),
        "versions": {"impactsim": _version(), "numpy": np.__version__,
                     "numba": numba.__version__, "python": platform.python_version()},
    }
    for p in passes:  # one level deep: a pass may add keys to an existing table ("bodies")
        for key, val in p.summary(model).items():
            if isinstance(val, dict) and isinstance(summary.get(key), dict):
                for k2, v2 in val.items():
                    if isinstance(v2, dict) and isinstance(summary[key].get(k2), dict):
                        summary[key][k2].update(v2)
                    else:
                        summary[key][k2] = v2
            else:
                summary[key] = val
    write_summary(out / "summary.json", summary)
    if case.output.fragment_histogram and "fragments" in summary:
        from impactsim.output.fragments import write_fragment_histogram

        write_fragment_histogram(out / "fragments.png", summary["fragments"], case.run.name)
    if progress:
        bar.log(_timing_table(timings, wall))
    return summary


def _timing_table(timings: dict[str, float], wall: float) -> str:
    lines = [f"{'pass':<24}{'seconds':>10}{'share':>8}"]
    for k, v in sorted(timings.items(), key=lambda kv: -kv[1]):
        lines.append(f"{k:<24}{v:>10.3f}{100 * v / wall if wall > 0 else math.nan:>7.1f}%")
    lines.append(f"{'total (wall)':<24}{wall:>10.3f}")
    return "\n".join(lines)


def _version() -> str:
    from impactsim import __version__

    return __version__
