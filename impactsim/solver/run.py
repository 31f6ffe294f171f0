"""Run a case: mesh, build the state and the passes, integrate, write the outputs."""

from __future__ import annotations

import math
import platform
import time as wallclock
from pathlib import Path
from types import SimpleNamespace

import numpy as np

from impactsim.case.schema import Case
from impactsim.model import ERODED, Model
from impactsim.output.fields import SUMMARY_UNITS
from impactsim.output.fields import header as history_header
from impactsim.solver import checkpoint as ckpt
from impactsim.solver.build import build_model
from impactsim.solver.derived import body_velocities, velocity_columns, wall_measures
from impactsim.solver.formulation import resolve_element
from impactsim.solver.loop import Simulation, SimulationStopped
from impactsim.solver.pipeline import build_passes, mach_warnings

CORE_COLUMNS = ["time", "step", "dt", "kinetic_energy", "internal_energy", "viscous_energy",
                "contact_dissipated", "external_work", "eroded_energy", "half_step_energy",
                "total_energy",
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
        cell["cell_id"] = np.arange(cell["status"].shape[0], dtype=np.int32)
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
            "specific_internal_energy": src.energy,
            "cell_id": np.arange(src.status.shape[0], dtype=np.int32), "jc_damage": src.damage}


_CELL_ARRAYS = ("conn", "sdev", "pressure", "eps_p", "temperature", "status", "elem_body",
                "elem_mass", "vol", "energy", "damage")


def frame_snapshot(model: Model) -> SimpleNamespace:
    """Copies of the arrays a frame reads (``frame_fields``, ``frame_cells``), with the
    attribute names of the Model and its blocks: the frame's fields are derived from them in
    the writer's thread while the run goes on (output/series.py ``write_later``), so the run
    itself only copies (sphere-plate's 164k tets: 1.7 CPU ms a frame, where deriving the
    fields, tensors and the live-cell selection took 19 ms of the run's own thread)."""
    def copy(src):
        return SimpleNamespace(**{k: getattr(src, k).copy() for k in _CELL_ARRAYS})

    snap = copy(model)
    snap.x, snap.x0, snap.v = model.x.copy(), model.x0.copy(), model.v.copy()
    snap.blocks = [copy(b) for b in model.blocks]
    return snap


def frame_args(snap, fields) -> tuple:
    """(points, cells, point data, cell data, keep) of a frame from ``frame_snapshot``, only
    the fields named in ``fields`` (None: all)."""
    point, cell = frame_fields(snap)
    if fields is not None:
        point = {k: v for k, v in point.items() if k in fields}
        cell = {k: v for k, v in cell.items() if k in fields}
    cells, keep = frame_cells(snap)
    return snap.x, cells, point, cell, keep


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
             meshes: list | None = None, overwrite: bool = True, resume: bool = False) -> dict:
    """Run `case`, writing series.pvd + frames, history.csv, summary.json and case.resolved.toml
    into out_dir (default out/<run name>). Returns the summary dict. A run that has to stop
    (a signal, a failed check, a non-finite state, a collapsing step) still writes its last
    frame and a summary with the reason (summary["stopped"]; the CLI exits 3). SIGTERM and
    SIGINT are watched for the whole run (solver/stop.py).

    A folder holding an earlier run's frames is cleared first, or refused (SimulationError)
    when overwrite is False (output/rundir.py). progress=False also silences the log lines
    (warnings are still printed). resume=True continues the run in out_dir from its last
    checkpoint (solver/checkpoint.py)."""
    from impactsim.kernel_cache import CompileCounter
    from impactsim.solver.stop import watching

    with watching() as stops, CompileCounter() as compiled:
        return _run(case, out_dir, progress, meshes, stops, overwrite, resume, compiled)


def output_folder(case: Case, out_dir: Path | None) -> Path:
    """The run's folder, created; an unusable one is a SimulationError naming the key."""
    out = Path(out_dir) if out_dir is not None else (
        case.output.directory or Path("out") / case.run.name)
    try:
        out.mkdir(parents=True, exist_ok=True)
        probe = out / ".impactsim-write-test"
        probe.write_bytes(b"")
        probe.unlink()
    except OSError as err:
        raise SimulationError(f"{_label(case)}output.directory: cannot write to {out}: "
                              f"{err.strerror or err}") from None
    return out


def _label(case: Case) -> str:
    return f"{case.source}: " if case.source is not None else ""


def _run(case: Case, out_dir, progress: bool, meshes, stops, overwrite: bool,
         resume: bool, compiled) -> dict:
    import numba

    from impactsim.case import case_to_dict
    from impactsim.case.estimate import (RE_ESTIMATE_SECONDS, RE_ESTIMATE_SHARE, check_fits,
                                         estimate_cost, re_estimate, re_estimate_line)
    from impactsim.checks import CheckFailed, CheckLog
    from impactsim.output.history import HistoryWriter
    from impactsim.output.progress import Progress
    from impactsim.output.series import SeriesWriter
    from impactsim.output.summary import write_resolved_case, write_summary
    from impactsim.solver.stop import RunStopped, checkpoint_on_stop
    from impactsim.solver.watch import NonFinite, Watch, describe_gain

    start = wallclock.perf_counter()
    out = output_folder(case, out_dir)
    from impactsim.output import rundir

    try:
        saved = ckpt.open_resume(out, case_to_dict(case)) if resume else None
        if not resume:
            rundir.prepare(out, overwrite)
    except (rundir.OutputExists, ckpt.CheckpointError) as err:
        raise SimulationError(str(err)) from None
    bar = Progress(case.run.end_time, enabled=progress)
    info = bar.log if progress else (lambda msg: None)
    checks = CheckLog(lambda msg: bar.log("warning: " + msg))
    timings: dict[str, float] = {}
    chk = case.checks
    sim = model = None
    estimate = None

    def write_or_fail(what: str, fn, *args):
        try:
            fn(*args)
        except OSError as err:
            raise SimulationError(f"{_label(case)}output.directory: cannot write {what} in "
                                  f"{out}: {err.strerror or err}") from None

    try:
        write_or_fail("case.resolved.toml", write_resolved_case, out / "case.resolved.toml",
                      case_to_dict(case))
        check_fits(case, estimate_cost(case, speed=_NO_SPEED))
        t = wallclock.perf_counter()
        if meshes is None:
            from impactsim.mesh import mesh_bodies

            meshes = mesh_bodies(case)
        timings["meshing"] = wallclock.perf_counter() - t
        from impactsim.solver.footprint import case_memory_warning

        memory = case_memory_warning(case, sum(len(m[1]) for m in meshes),
                                     sum(len(m[0]) for m in meshes))
        if memory:
            bar.log("warning: " + memory)
        try:
            model = build_model(case, meshes)
        except ValueError as err:
            raise SimulationError(f"{case.run.name}: {err}") from err
        _initial_checks(case, meshes, checks)
        estimate = estimate_cost(case, meshes=meshes)
        n_elem = model.n_elem + sum(b.n_elem for b in model.blocks)
        numba.set_num_threads(thread_count(case.run.threads, n_elem))
        passes = build_passes(case, model)
        info(f"{case.run.name}: {model.n_node} nodes, {n_elem} elements, "
                f"{model.n_body} bodies; passes: " + (", ".join(p.name for p in passes) or "none"))
        info("estimate: " + estimate.line() + "".join(
            "; " + line for line in estimate.detail_lines()))
        for w in mach_warnings(case):
            bar.log("warning: " + w)
        element = resolve_element(case)
        if case.run.subcycle and any(p.name == "fracture.separation" for p in passes):
            raise SimulationError(
                f"{_label(case)}run.subcycle: node separation (a material's "
                "failure.fracture_strain) cannot run with subcycling yet; set run.subcycle = 0")
        sim = Simulation(model, passes, cfl=case.run.cfl, element=element,
                         cq=case.run.q_quadratic, cl=case.run.q_linear,
                         dt_collapse=case.run.dt_collapse, subcycle=case.run.subcycle)
        if chk.negative_volume == "erode":
            sim.on_inverted = lambda s, dt: _erode_inverted(s, checks)
        # the energy watch lives on the Simulation so that a checkpoint carries its state
        sim.watch = Watch(sim, energy_limit=chk.energy_balance)
        if saved is not None:
            saved = ckpt.resume_into(sim, saved)
            info(f"resumed from step {model.step}, t = {model.time:.6g} s")
        schedule = ckpt.Schedule(case.output.checkpoint_every, model.step, model.time)
        timings["setup"] = wallclock.perf_counter() - start - timings["meshing"]
    except CheckFailed as err:
        raise SimulationError(f"{_label(case)}checks.{str(err)[6:]}") from None
    except RunStopped as err:
        reason = f"{err} before the first step (while setting up)"
        bar.log(f"stopped: {reason}")
        bar.close()
        summary = {"case": case.run.name, "source": str(case.source) if case.source else None,
                   "steps": 0, "time": 0.0, "end_time": case.run.end_time,
                   "wall_seconds": wallclock.perf_counter() - start, "stopped": reason,
                   "stop": {"reason": reason, "kind": "signal", "signal": stops.signal},
                   "checks": checks.summary(), "seconds_per_pass": timings}
        with stops.finishing():
            write_or_fail("summary.json", write_summary, out / "summary.json", summary)
        return summary

    # frames are written by threads of their own while the run goes on (output/series.py)
    series = SeriesWriter(out, compression=case.output.compression, background=True)
    pass_series: dict[str, SeriesWriter] = {}  # the passes' own series (particles)

    def pass_writer(key):
        return SeriesWriter(out, prefix=key, pvd_name=f"{key}.pvd",
                            compression=case.output.compression, background=True)
    fields = case.output.fields
    columns = list(dict.fromkeys(CORE_COLUMNS + (["hourglass_energy"] if model.blocks else [])
                                 + velocity_columns(model)
                                 + [k for p in passes for k in p.history(model)]))
    if saved is None:
        history = HistoryWriter(out / "history.csv", columns, header=history_header)
    else:  # the writers go on where the checkpoint left them
        history = HistoryWriter.reopen(out / "history.csv", columns, saved["history_bytes"],
                                       header=history_header)
        series.resume(saved["series"])
        for key, pos in saved["pass_series"].items():
            pass_series[key] = pass_writer(key)
            pass_series[key].resume(pos)
    # the history's penetration measure is taken in its meter's own thread while the run goes
    # on (contact/diagnostics.py); the history writer keeps the rows in order as it comes
    meters = _measures_later(passes)
    times = frame_times(case)
    next_frame = 0 if saved is None else saved["next_frame"]
    end = case.run.end_time
    eps_t = 1e-9 * end
    e0 = None if saved is None else saved["e0"]
    stopped = None
    stop_kind = None
    output_error = None
    first_step_seconds = None
    t_out = 0.0
    watch = sim.watch
    revised = None  # the run's re-estimate of itself (case/estimate.py re_estimate)
    # its clock starts after the first steps, whose calls load the compiled kernels
    loop_start, loop_step0 = None, model.step + 2

    def write_frame():
        nonlocal t_out
        t1 = wallclock.perf_counter()
        snap = frame_snapshot(model)  # the fields are derived in the writer's thread
        series.write_later(model.time, lambda: frame_args(snap, fields))
        for pa in passes:  # passes with series of their own (particles) write with every frame
            for key, (points, data) in (pa.frame(model) if hasattr(pa, "frame") else {}).items():
                if key not in pass_series:
                    pass_series[key] = pass_writer(key)
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
        row.update(body_velocities(model))
        for pa in passes:
            row.update(pa.history(model))
        history.row(row)
        _hourglass_check(row, chk, checks)
        t_out += wallclock.perf_counter() - t1
        return row

    # what a checkpoint needs of the run besides the Simulation (solver/checkpoint.py)
    def run_bookkeeping():
        for meter in meters:  # their measures done first: the state a checkpoint walks is still
            meter.wait()
        return {"next_frame": next_frame, "e0": e0, "history_bytes": history.position(),
                "series": series.position(),
                "pass_series": {k: w.position() for k, w in pass_series.items()}}

    sim.run_bookkeeping = run_bookkeeping
    try:
        if saved is None:
            e0 = history_row()["total_energy"]
            watch.after_step()
        if saved is None and times.size and times[0] <= eps_t:
            write_frame()
            next_frame = 1
        if estimate.steps_needed > case.run.max_steps:
            bar.log(f"warning: run.max_steps = {case.run.max_steps:,} will stop the run before "
                    f"its end time (≈ {estimate.steps_needed:,} steps needed)")
        while model.time < end - eps_t:
            if model.step >= case.run.max_steps:
                stopped = f"max_steps = {case.run.max_steps} reached at t = {model.time:.6g} s"
                stop_kind = "max_steps"
                break
            target = times[next_frame] if next_frame < len(times) else end
            if loop_start is None and model.step >= loop_step0:
                loop_start = wallclock.perf_counter()
            sim.step(target - model.time)
            stops.urgent = False  # compiled and stepping: a signal waits for the step's end
            if abs(model.time - target) <= eps_t:
                model.time = float(target)  # no round-off drift of frame times
            if first_step_seconds is None:
                first_step_seconds = wallclock.perf_counter() - start
            watch.after_step()
            if watch.gaining() and chk.energy_balance_action != "ignore":
                checks.trigger("energy_balance", chk.energy_balance_action, describe_gain(watch))
            if chk.time_step_floor > 0.0 and sim.cfl * sim.dt_stable < chk.time_step_floor:
                _time_step_floor(sim, chk, checks)
            if model.step % case.output.history_every == 0:
                history_row()
            while next_frame < len(times) and model.time >= times[next_frame] - eps_t:
                write_frame()
                next_frame += 1
            bar.update(model.time, model.step, sim.dt)
            if revised is None and loop_start is not None and model.step > loop_step0 and (
                    model.time >= RE_ESTIMATE_SHARE * end
                    or wallclock.perf_counter() - loop_start >= RE_ESTIMATE_SECONDS):
                now = wallclock.perf_counter()
                revised = re_estimate(
                    estimate, time=model.time, end_time=end, steps=model.step - loop_step0,
                    dt=sim.next_dt(), loop_seconds=now - loop_start, elapsed=now - start,
                    frames_left=len(times) - next_frame, frames=len(times))
                info(re_estimate_line(revised))
            if schedule.due(model.step, model.time):
                with stops.finishing():
                    ckpt.write_checkpoint(sim, out)
            if stops.requested:
                stopped = f"{stops.requested} at t = {model.time:.6g} s (step {model.step})"
                stop_kind = "signal"
                break
    except SimulationStopped as err:
        stopped, stop_kind = str(err), "simulation"
    except NonFinite as err:
        stopped, stop_kind = str(err), "non-finite"
    except CheckFailed as err:
        stopped, stop_kind = str(err), "check"
    except (RunStopped, KeyboardInterrupt):
        stopped = f"{stops.requested or 'interrupted'} at t = {model.time:.6g} s (step {model.step})"
        stop_kind = "signal"
    except OSError as err:  # a full disk, a folder removed under the run
        output_error = f"{_label(case)}output.directory: cannot write in {out}: " \
                       f"{err.strerror or err}"
        stopped, stop_kind = output_error, "output"
    finally:
        with stops.finishing():
            if stopped is not None:
                bar.log(f"stopped: {stopped}")
                try:
                    history_row()
                    write_frame()
                except Exception:  # the state may be non-finite, the disk full: what is
                    pass            # written so far stands, whole
                checkpoint_on_stop(sim, out, case)
            try:
                history.close()
            except OSError as err:
                output_error = output_error or (f"{_label(case)}output.directory: cannot write "
                                                f"history.csv in {out}: {err.strerror or err}")
            finally:
                for meter in meters:
                    meter.close()
            bar.close()

    def close_writers():
        """Wait for the frames still being written (output/series.py)."""
        nonlocal output_error, t_out
        t1 = wallclock.perf_counter()
        for writer in (series, *pass_series.values()):
            try:
                writer.close()
            except OSError as err:
                output_error = output_error or (
                    f"{_label(case)}output.directory: cannot write a frame in {out}: "
                    f"{err.strerror or err}")
        t_out += wallclock.perf_counter() - t1

    # the summary is made while the writers' threads finish the last frames
    try:
        energies = sim.energies()
        if model.blocks:
            from impactsim.solver.blocks import hourglass_warning

            if hourglass_warning(energies):
                bar.log("warning: " + hourglass_warning(energies))
        timings.update({k: v for k, v in sim.timings.items()})
        timings["watch"] = watch.seconds
        summary = {
            "case": case.run.name,
            "source": str(case.source) if case.source else None,
            "nodes": model.n_node, "elements": n_elem, "bodies": body_summary(model),
            "steps": model.step, "time": model.time, "end_time": end,
            "wall_seconds": None, "seconds_to_first_step": first_step_seconds,
            "seconds_per_pass": timings,
            "ns_per_element_step": (1e9 * sim.timings["element"] / (n_elem * model.step)
                                    if model.step and n_elem else None),
            "passes": [p.name for p in passes],
            "element": element,
            "energy": energies,
            "energy_balance_error": ((energies["total_energy"] - e0) / max(abs(e0), 1e-300)
                                     if e0 else 0.0),
            "stopped": stopped,
            "threads": numba.get_num_threads(),
            "versions": {"impactsim": _version(), "numpy": np.__version__,
                         "numba": numba.__version__, "python": platform.python_version()},
        }
        summary.update(watch.report())
        if sim.sub is not None:
            summary["subcycle"] = sim.sub.report(model.step)
        if stopped is not None:
            summary["stop"] = {"reason": stopped, "kind": stop_kind,
                               "signal": stops.signal if stop_kind == "signal" else None}
        summary["estimate"] = {"elements": estimate.elements, "steps": estimate.steps,
                               "wall_seconds": estimate.wall_seconds,
                               "memory_bytes": estimate.memory_bytes, "threads": estimate.threads,
                               "seconds": estimate.seconds, "crush_factor": estimate.crush_factor}
        if revised is not None:
            summary["re_estimate"] = revised
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
        unconverged, in_contact = unconverged_contact(summary)
        share = unconverged / in_contact if in_contact else 0.0
        if (unconverged and share > chk.unconverged_contact_share
                and chk.unconverged_contact != "ignore"):
            try:
                checks.trigger("unconverged_contact", chk.unconverged_contact,
                               f"{unconverged} step(s) whose projected contact rounds did not "
                               f"converge, {100 * share:.3g} % of the {in_contact} step(s) in "
                               f"contact (limit {100 * chk.unconverged_contact_share:g} %)",
                               count=unconverged)
            except CheckFailed as err:
                if summary["stopped"] is None:
                    summary["stopped"] = str(err)
                    summary["stop"] = {"reason": str(err), "kind": "check", "signal": None}
        for name, vals in wall_measures(model).items():
            summary["bodies"].setdefault(name, {}).update(vals)
        summary["units"] = SUMMARY_UNITS
        summary["checks"] = checks.summary()
        # compiling is part of the run's wall time; the kernels are cached for the next run,
        # which computes the same bits (impactsim/numba_linking.py)
        summary["kernels_compiled"] = len(compiled.kernels)
        if compiled.kernels:
            info(f"note: {len(compiled.kernels)} kernel(s) compiled in this run, now cached for "
                 "the next (`make setup` compiles the bundled cases' kernels ahead)")
        for line in checks.closing_lines():
            bar.log(line)
        info(f"energy balance: {100 * summary['energy_balance_error']:+.3g} % at the end, "
                f"largest {100 * watch.worst:+.3g} % at t = {watch.worst_time:.6g} s")
    finally:
        close_writers()
    timings["output"] = t_out
    wall = wallclock.perf_counter() - start
    summary["wall_seconds"] = wall
    with stops.finishing():
        try:
            write_summary(out / "summary.json", summary)
        except OSError as err:
            output_error = output_error or (f"{_label(case)}output.directory: cannot write "
                                            f"summary.json in {out}: {err.strerror or err}")
    if case.output.fragment_histogram and "fragments" in summary:
        from impactsim.output.fragments import write_fragment_histogram

        with stops.finishing():
            try:
                write_fragment_histogram(out / "fragments.png", summary["fragments"],
                                         case.run.name)
            except OSError as err:
                output_error = output_error or (f"{_label(case)}output.directory: cannot write "
                                                f"fragments.png in {out}: {err.strerror or err}")
    if output_error:
        raise SimulationError(output_error)
    if progress:
        bar.log(_timing_table(timings, wall))
        bar.log(f"outputs in {out}/: series.pvd (frames), history.csv, summary.json, "
                "case.resolved.toml")
    return summary


_NO_SPEED = {"ns_per_element_step": 0.0, "seconds_per_step": 0.0, "source": "none"}


def _measures_later(passes) -> list:
    """Have the contact passes take the history's penetration measure in the meter's thread
    (``ContactContext.measure_later``); returns their meters."""
    from impactsim.contact.passes import ContactContext

    contexts = {id(p.ctx): p.ctx for p in passes
                if isinstance(getattr(p, "ctx", None), ContactContext)}
    for ctx in contexts.values():
        ctx.measure_later = True
    return [ctx.meter for ctx in contexts.values()]


def _initial_checks(case: Case, meshes: list, checks) -> None:
    """checks.initial_penetration: bodies inside each other or behind a wall at t = 0."""
    from impactsim.checks.overlap import initial_overlaps

    action = case.checks.initial_penetration
    if action == "ignore":
        return
    found = initial_overlaps(case, meshes)
    if found:
        worst = max(found, key=lambda o: o.depth)
        text = "; ".join(f"{o.what} overlap by {o.depth * 1e3:.4g} mm ({o.nodes} node(s))"
                         for o in found)
        checks.trigger("initial_penetration", action,
                       f"at t = 0: {text} (deepest {worst.depth * 1e3:.4g} mm): move the "
                       "bodies apart", count=len(found))


def unconverged_contact(summary: dict) -> tuple[int, int]:
    """(steps whose projected contact rounds did not converge, steps in contact) from the
    passes' tables of a summary: the contact passes report under "contact.<name>" (the shared
    projection counts once, in the pass that reports it), another pass at the top level; steps
    in contact default to the run's steps."""
    tables = [summary] + [v for k, v in summary.items()
                          if k.startswith("contact") and isinstance(v, dict)]
    unconverged = sum(int(t.get("unconverged_steps") or 0) for t in tables)
    in_contact = max([int(t.get("steps_in_contact") or 0) for t in tables] + [0])
    return unconverged, in_contact or int(summary.get("steps") or 0)


def _hourglass_check(row: dict, chk, checks) -> None:
    """checks.hourglass_share, when the run has an hourglass_energy column (hexahedra)."""
    hg = row.get("hourglass_energy")
    if hg is None or chk.hourglass_share_action == "ignore":
        return
    base = row.get("kinetic_energy", 0.0) + row.get("internal_energy", 0.0)
    if base > 0.0 and hg / base > chk.hourglass_share:
        checks.trigger("hourglass_share", chk.hourglass_share_action,
                       f"hourglass energy is {100 * hg / base:.3g} % of kinetic + internal at "
                       f"t = {row['time']:.6g} s (limit {100 * chk.hourglass_share:g} %)")


def _time_step_floor(sim, chk, checks) -> None:
    """checks.time_step_floor: stop, or erode the element that sets the step."""
    m = sim.model
    e = sim.worst_element
    msg = (f"time step {sim.cfl * sim.dt_stable:.3e} s below the floor "
           f"{chk.time_step_floor:.3e} s at t = {m.time:.6g} s, set by element {e} (body "
           f"{m.body_names[m.elem_body[e]]!r})")
    checks.trigger("time_step_floor", chk.time_step_floor_action, msg)
    erode_elements(sim, np.array([e]))


def _erode_inverted(sim, checks) -> None:
    """checks.negative_volume = erode: remove the inverted elements and go on."""
    from impactsim.solver.nodal import element_volumes

    m = sim.model
    vol = np.zeros(m.n_elem)
    element_volumes(m.x, m.conn, m.status, vol)
    bad = np.flatnonzero((vol <= 0.0) & (m.status != ERODED))
    if not len(bad):
        return
    b = m.body_names[m.elem_body[bad[0]]]
    checks.trigger("negative_volume", "erode",
                   f"{len(bad)} element(s) inverted at t = {m.time:.6g} s, first {bad[0]} "
                   f"(body {b!r}): eroded", count=len(bad))
    erode_elements(sim, bad)


def erode_elements(sim, elements: np.ndarray) -> None:
    """Remove `elements` (status ERODED): their internal energy goes to the eroded term, their
    mass stays on their nodes, the forces of their nodes are recomputed without them and the
    next stable step is taken without them. Contact surfaces are not rebuilt here (a pass that
    tracks surfaces, fracture's, does that for its own removals)."""
    m = sim.model
    elements = elements[m.status[elements] != ERODED]
    if not len(elements):
        return
    m.energy_terms["eroded"] += float((m.elem_mass[elements] * m.energy[elements]).sum())
    m.status[elements] = ERODED
    sim.refresh_forces(elements)
    sim.refresh_stable_step()


def _timing_table(timings: dict[str, float], wall: float) -> str:
    lines = [f"{'pass':<24}{'seconds':>10}{'share':>8}"]
    for k, v in sorted(timings.items(), key=lambda kv: -kv[1]):
        lines.append(f"{k:<24}{v:>10.3f}{100 * v / wall if wall > 0 else math.nan:>7.1f}%")
    lines.append(f"{'total (wall)':<24}{wall:>10.3f}")
    return "\n".join(lines)


def _version() -> str:
    from impactsim import __version__

    return __version__
