"""Checkpoint and resume: a resumed run gives the same bits as an uninterrupted one (a bar on a
wall; a sphere through a plate with contact, fracture and particles), and runs killed with
SIGKILL at random moments leave whole files only, from which they resume to the same bits."""

import json
import os
import random
import signal
import subprocess
import sys
import time
from pathlib import Path

import meshio
import numpy as np
import pytest

from impactsim.case import load_case
from impactsim.output.series import read_collection
from impactsim.solver import checkpoint as ckpt
from impactsim.solver.run import SimulationError, run_case
from tests.cli.test_run import BAR
from tests.killed import whole_history

ROOT = Path(__file__).resolve().parents[2]

PLATE = """
[run]
name = "spc"
end_time = "3 us"
[[material]]
name = "plate-al"
library = "al-2024-t3"
failure = { spall_strength = "1.6 GPa", spall_time = "10 ns", loosening = 0.03 }
[[material]]
name = "sphere-steel"
library = "steel-4340"
failure = { spall_strength = "7 GPa", loosening = 0.03 }
[[body]]
name = "plate"
material = "plate-al"
shape = "plate"
size = ["16 mm", "16 mm", "2 mm"]
position = ["0 mm", "0 mm", "-1 mm"]
mesh_size = "1.6 mm"
mesher = "structured"
[[body]]
name = "sphere"
material = "sphere-steel"
shape = "sphere"
radius = "4 mm"
position = ["0 mm", "0 mm", "4.02 mm"]
mesh_size = "3 mm"
velocity = ["0 m/s", "0 m/s", "-2 km/s"]
[contact]
passes = ["node-face", "edge-edge"]
[fracture]
particles_per_element = 1
particle_collisions = true
[output]
frames = 3
checkpoint_every = "0.7 us"
"""


def _same_outputs(a: Path, b: Path) -> None:
    assert (a / "history.csv").read_bytes() == (b / "history.csv").read_bytes()
    for pvd in ("series.pvd", "particles.pvd"):
        if (a / pvd).exists():
            assert (a / pvd).read_text() == (b / pvd).read_text()
            for _, f in read_collection(a / pvd):
                assert f.read_bytes() == (b / f.name).read_bytes(), f.name
    sa, sb = (json.loads((d / "summary.json").read_text()) for d in (a, b))
    for key in ("steps", "time", "energy", "energy_balance_error", "bodies", "particles"):
        assert sa.get(key) == sb.get(key), key


def _resume_from_an_early_checkpoint(text, tmp_path, keep_first):
    case_file = tmp_path / "case.toml"
    case_file.write_text(text)
    case = load_case(case_file)
    run_case(case, tmp_path / "whole", progress=False)
    run_case(case, tmp_path / "cut", progress=False)
    found = ckpt.list_checkpoints(tmp_path / "cut")
    assert len(found) == ckpt.KEEP
    for late in found[keep_first:]:  # as if the run had been stopped after the first kept
        late.unlink()
    step = int(np.load(found[0])["__step__"])
    s = run_case(load_case(case_file), tmp_path / "cut", progress=False, resume=True)
    assert 0 < step < s["steps"]
    _same_outputs(tmp_path / "whole", tmp_path / "cut")
    return s


def test_resumed_bar_is_bit_identical(tmp_path):
    _resume_from_an_early_checkpoint(BAR.replace("[output]", "[output]\ncheckpoint_every = 40"),
                                     tmp_path, 1)


def test_resumed_sphere_through_plate_is_bit_identical(tmp_path):
    """Contact rows, fracture state (with the Tuler-Butcher spall integrals: a spall time
    short enough for the plate to open in 3 us), particles and their series all come
    back."""
    s = _resume_from_an_early_checkpoint(PLATE, tmp_path, 1)
    assert s["particles"] > 0 and s["bodies"]["plate"]["hole"]["area"] > 0


def test_resumed_subcycled_sphere_through_plate_is_bit_identical(tmp_path):
    """Subcycling's levels, intervals and positions of the last updates come back too (the
    checkpoints, by time, fall within cycles)."""
    # a plate of coarse cells (a part of its own: level 1) struck by a finely meshed sphere
    text = (PLATE.replace('end_time = "3 us"', 'end_time = "3 us"\nsubcycle = 3')
            .replace('size = ["16 mm", "16 mm", "2 mm"]', 'size = ["20 mm", "20 mm", "2 mm"]')
            .replace('mesh_size = "1.6 mm"', 'mesh_size = "1.4 mm"')
            .replace('mesh_size = "3 mm"', 'mesh_size = "0.6 mm"'))
    s = _resume_from_an_early_checkpoint(text, tmp_path, 1)
    assert s["subcycle"]["part_updates_share"] < 0.97 and s["particles"] > 0


def test_resumed_hex_plate_is_bit_identical(tmp_path):
    """The same with the plate in hexes: the hex blocks' fracture state (free quads, criteria
    scratch), the hex contact surface and the particles come back."""
    text = PLATE.replace('mesher = "structured"', 'mesher = "structured"\nelement = "hex8"\n'
                         'hourglass = "stiffness"\nhourglass_coefficient = 0.15')
    s = _resume_from_an_early_checkpoint(text, tmp_path, 1)
    assert s["bodies"]["plate"]["debris"]["particles"] > 0


def test_resumed_separating_plate_is_bit_identical(tmp_path):
    """The plate with node separation [Z] and distortion erosion instead of spall: the node
    families, the split sets and the released tets' step limit, the contact surface reconnected
    in place, all come back."""
    text = PLATE.replace('failure = { spall_strength = "1.6 GPa", spall_time = "10 ns", loosening = 0.03 }',
                         "failure = { fracture_strain = 0.3 }", 1).replace(
        "[fracture]\n", '[fracture]\ndistortion_interval = "20 ns"\n')
    s = _resume_from_an_early_checkpoint(text, tmp_path, 1)
    assert s["fracture"]["separation"]["release_steps"] > 0


def test_state_walk_saves_everything_but_configuration(tmp_path):
    from impactsim.mesh import mesh_body
    from impactsim.solver.build import build_model
    from impactsim.solver.loop import Simulation
    from impactsim.solver.pipeline import build_passes

    (tmp_path / "c.toml").write_text(PLATE)
    case = load_case(tmp_path / "c.toml")
    meshes = [mesh_body(b) for b in case.bodies]
    model = build_model(case, meshes)
    sim = Simulation(model, build_passes(case, model), cfl=case.run.cfl)
    for _ in range(5):
        sim.step()
    entries, skipped = ckpt.collect({"sim": sim})
    assert all("dtype" in s or "object" in s for s in skipped), skipped
    assert "sim/model/x|a" in entries and "sim/model/energy_terms|dict" in entries
    for name, value in vars(model).items():  # every array of the model, whatever it holds
        if isinstance(value, np.ndarray):
            assert f"sim/model/{name}|a" in entries or f"sim/model/{name}|alias" in entries


def test_resume_refuses_another_case_or_no_checkpoint(tmp_path):
    case_file = tmp_path / "case.toml"
    case_file.write_text(BAR)
    run_case(load_case(case_file), tmp_path / "r", progress=False)
    with pytest.raises(SimulationError, match="no checkpoint"):
        run_case(load_case(case_file), tmp_path / "r", progress=False, resume=True)
    with pytest.raises(SimulationError, match="the case differs"):
        run_case(load_case(case_file, ["run.cfl=0.3"]), tmp_path / "r", progress=False,
                 resume=True)


def test_schedule_by_steps_and_time():
    s = ckpt.Schedule(10)
    assert [k for k in range(1, 35) if s.due(k, 0.0)] == [10, 20, 30]
    t = ckpt.Schedule(1e-6, 0, 0.0)
    times = [0.4e-6, 0.9e-6, 1.05e-6, 1.6e-6, 2.5e-6, 2.6e-6]
    assert [x for x in times if t.due(0, x)] == [1.05e-6, 2.5e-6]
    assert not ckpt.Schedule(0).active


def _whole_files(out: Path) -> None:
    """Every visible file of the run folder is complete."""
    for f in out.rglob("*"):
        if f.is_dir() or f.name.startswith("."):
            continue
        if f.suffix == ".npz":
            with np.load(f, allow_pickle=False) as z:
                for k in z.files:
                    z[k]
        elif f.suffix == ".vtu":
            meshio.read(f)
        elif f.suffix == ".pvd":
            for _, frame in read_collection(f):
                assert frame.exists()
        elif f.name == "history.csv":
            # (a resumed run cuts a torn last line away with the rows after its checkpoint)
            lines = whole_history(f.read_text()).splitlines()
            n = lines[0].count(",")
            assert all(line.count(",") == n for line in lines)
        elif f.suffix == ".json":
            json.loads(f.read_text())


def _reference_run(cmd: list[str], env: dict, out: Path) -> dict:
    """The uninterrupted run to compare with, in a process of its own like the runs under test,
    after a short run of the same case that leaves every kernel it needs in numba's cache. A
    kernel compiled in a process and the same kernel loaded from the cache can differ in the
    last digits (docs/architecture.md, "The step, and who owns which arrays"): the pytest process may hold fresh compilations from
    earlier tests, and the first process to need an uncached kernel compiles it, so only runs
    that all load from the cache can be compared bit for bit. Returns its summary."""
    prime = out.parent / (out.name + "-prime")
    subprocess.run(cmd + ["-o", str(prime), "--set", 'run.end_time="2 us"'], env=env,
                   check=True, capture_output=True)
    subprocess.run(cmd + ["-o", str(out)], env=env, check=True, capture_output=True)
    return json.loads((out / "summary.json").read_text())


def test_killed_runs_leave_whole_files_and_resume_to_the_same_bits(tmp_path):
    text = BAR.replace('end_time = "20 us"', 'end_time = "3 ms"').replace(
        "frames = 4", "frames = 40\ncheckpoint_every = 500\nhistory_every = 5")
    case_file = tmp_path / "case.toml"
    case_file.write_text(text)
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    cmd = [sys.executable, "-m", "impactsim.cli", "run", str(case_file), "-q"]
    _reference_run(cmd, env, tmp_path / "whole")
    rng = random.Random(15)
    out = tmp_path / "killed"
    started = False
    kills = []
    for attempt in range(4):
        args = cmd + (["--resume", str(out)] if started else ["-o", str(out), "--overwrite"])
        size0 = (out / "history.csv").stat().st_size if (out / "history.csv").exists() else 0
        proc = subprocess.Popen(args, env=env, stdout=subprocess.DEVNULL,
                                stderr=subprocess.PIPE)
        if attempt == 0:  # in the start: imports, case, meshing (a warm run starts in ~1 s)
            time.sleep(rng.uniform(0.2, 0.8))
        else:  # once the run goes on, after its history has grown by a random amount (by
            # progress, not by the clock: on a quiet machine the run outpaces any sleep)
            target = size0 + rng.uniform(2e3, 4e5)
            t0 = time.monotonic()
            while proc.poll() is None and time.monotonic() - t0 < 60 and (
                    not (out / "history.csv").exists()
                    or (out / "history.csv").stat().st_size <= target):
                time.sleep(0.005)
        proc.send_signal(signal.SIGKILL)
        proc.wait()
        _whole_files(out)
        started = started or bool(ckpt.list_checkpoints(out))
        summary = out / "summary.json"
        kills.append((started, summary.exists() and json.loads(summary.read_text())["time"]))
    print(kills)
    assert started  # a kill came after a checkpoint: the later runs resumed
    assert not all(done for _, done in kills)  # and some came before the run's end
    if started:
        r = subprocess.run(cmd + ["--resume", str(out)], env=env, capture_output=True, text=True)
    else:
        r = subprocess.run(cmd + ["-o", str(out), "--overwrite"], env=env, capture_output=True,
                           text=True)
    assert r.returncode == 0, r.stderr
    assert not [f for f in out.rglob(".*") if f.is_file()]  # no temporary file left over
    _same_outputs(tmp_path / "whole", out)


def test_sigterm_stop_writes_a_checkpoint_the_run_resumes_from(tmp_path):
    """A run stopped by SIGTERM (exit 3) with checkpoints on writes a checkpoint of the state it
    stopped in (solver/stop.checkpoint_on_stop); --resume continues from it to the end, to the
    same final state as an uninterrupted run."""
    text = BAR.replace('end_time = "20 us"', 'end_time = "3 ms"').replace(
        "frames = 4", "frames = 4\ncheckpoint_every = 5000\nhistory_every = 5")
    case_file = tmp_path / "case.toml"
    case_file.write_text(text)
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    out = tmp_path / "stopped"
    cmd = [sys.executable, "-m", "impactsim.cli", "run", str(case_file), "-q"]
    whole = _reference_run(cmd, env, tmp_path / "whole")
    proc = subprocess.Popen(cmd + ["-o", str(out)], env=env, stdout=subprocess.DEVNULL,
                            stderr=subprocess.PIPE)
    t0 = time.monotonic()  # stop well before the first scheduled checkpoint (step 5000)
    while proc.poll() is None and time.monotonic() - t0 < 60 and (
            not (out / "history.csv").exists() or (out / "history.csv").stat().st_size < 6e4):
        time.sleep(0.005)
    proc.send_signal(signal.SIGTERM)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 3, err
    summary = json.loads((out / "summary.json").read_text())
    assert summary["stop"]["kind"] == "signal" and summary["time"] < 3e-3
    saved = ckpt.list_checkpoints(out)
    assert saved, "no checkpoint written on the stop"
    assert saved[-1].name == f"checkpoint_{summary['steps']:09d}.npz"
    r = subprocess.run(cmd + ["--resume", str(out)], env=env, capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    done = json.loads((out / "summary.json").read_text())
    assert done["stopped"] is None and done["steps"] == whole["steps"]
    assert done["energy"] == whole["energy"]  # the same bits of the final state
