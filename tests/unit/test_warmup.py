"""The warm-up step (impactsim/warmup.py, run by `make setup`): its scenes take the paths they
are there for, and the cache they leave serves a later process, which compiles nothing."""

import json
import os
import subprocess
import sys
from pathlib import Path

from impactsim.warmup import warm_up

ROOT = Path(__file__).resolve().parents[2]

_SECOND = """
import json
from impactsim.warmup import warm_up
print(json.dumps({k: v["compiled"] for k, v in warm_up(verbose=False).items()}))
"""


def test_warmup_scenes_cover_the_pipeline_and_leave_a_cache_a_later_process_uses():
    scenes = warm_up(verbose=False)  # compiles what the cache lacks, writes it
    s = {k: v["summary"] for k, v in scenes.items()}
    assert s["elastic-wall"]["passes"] == ["walls"]
    contact = s["contact"]
    assert contact["contact.node-face"]["corrected_pairs"] > 0
    assert contact["contact.edge-edge"]["candidate_pairs"] > 0
    # candidate lists kept over steps (contact/skin.py): built, then kept and filtered
    for name in ("contact.node-face", "contact.edge-edge"):
        assert 0 < contact[name]["candidate_list_builds"] < contact["steps"], name
    # the same scene on the threads (the parallel query and tet kernel) finds contact too
    assert s["contact-threads"]["contact.node-face"]["corrected_pairs"] > 0
    frac = s["fracture"]
    # the kept candidate lists followed the erosion (contact/skin.py, SkinList.follow)
    for name in ("contact.node-face", "contact.edge-edge"):
        assert frac[name]["candidate_list_follows"] > 0, name
    assert frac["particles"] > 0 and frac["fracture"]["eroded"] > 0
    assert frac["fracture.particles"]["particle_face_impacts"] > 0
    assert frac["fracture.particles"]["particle_collisions"] > 0
    assert "hole" in frac["bodies"]["plate"]  # the plate's hole measure ran
    # fracture and self-contact of hexes (fracture/hexes.py, contact/hexes.py)
    hexf = s["hex-fracture"]
    assert hexf["bodies"]["plate"]["debris"]["particles"] > 0  # hexes became particles
    assert hexf["fracture"]["eroded"] > 0 and "hole" in hexf["bodies"]["plate"]
    assert hexf["fracture.particles"]["particle_face_impacts"] > 0
    assert hexf["contact.edge-edge"]["candidate_pairs"] > 0
    # node separation released (tets: the surface reconnected in place; hexes: their corner
    # forces re-run), distortion erosion deleted cells
    assert s["separation"]["fracture"]["separation"]["new_nodes"] > 0
    assert s["separation-contact"]["fracture"]["separation"]["release_steps"] > 0
    assert "contact.node-face" in s["separation-contact"]["passes"]
    assert s["separation"]["fracture"]["distortion"]["deleted"] > 0
    assert s["separation-hex"]["fracture"]["separation"]["new_nodes"] > 0
    # with self-contact: the hex contact surface reconnected in place (HexSurface.reconnect)
    assert s["separation-hex"]["fracture"]["separation"]["release_steps"] > 0
    assert "contact.node-face" in s["separation-hex"]["passes"]
    # a fresh interpreter (same cache folder) loads every kernel and compiles none
    env = dict(os.environ, PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    p = subprocess.run([sys.executable, "-c", _SECOND], cwd=ROOT, env=env, check=True,
                       capture_output=True, text=True)
    compiled = json.loads(p.stdout.strip().splitlines()[-1])
    assert compiled == {name: [] for name in scenes}


def test_the_parallel_warmup_takes_every_scene_and_merges_the_workers_results():
    from impactsim.warmup import STAGES, scenes, warm_up_parallel

    staged = [name for stage in STAGES for group in stage for name in group]
    assert sorted(staged) == sorted(name for name, _, _ in scenes())  # each scene once
    # two worker processes on a warm cache: nothing to compile, and each scene's summary
    # comes back under its name, in the scenes' order
    warm_up(verbose=False, names=["jc-wall", "elastic-wall"])  # warm, whatever ran before
    out = warm_up_parallel(2, verbose=False, stages=((("jc-wall",), ("elastic-wall",)),))
    assert list(out) == ["elastic-wall", "jc-wall"]
    assert all(v["compiled"] == [] for v in out.values())
    assert out["jc-wall"]["summary"]["steps"] == 4


_LOCKED_COMPILE = """
import sys
from pathlib import Path
import numba
from impactsim.kernel_cache import serialize_cache_files

serialize_cache_files(Path(sys.argv[1]))

@numba.njit(cache=True)
def twice(x):
    return 2 * x

print("compiling", flush=True)
print(twice(21), flush=True)
"""


def test_cache_writes_wait_for_the_warmup_lock(tmp_path):
    """kernel_cache.serialize_cache_files: while another process holds the lock, a compiled
    kernel is not written to numba's cache; once it is released, it is."""
    import fcntl
    import time

    lock = tmp_path / "cache.lock"
    script = tmp_path / "kernel.py"
    script.write_text(_LOCKED_COMPILE)
    cache = tmp_path / "numba-cache"
    env = dict(os.environ, NUMBA_CACHE_DIR=str(cache),
               PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    with open(lock, "a") as held:
        fcntl.flock(held, fcntl.LOCK_EX)
        p = subprocess.Popen([sys.executable, str(script), str(lock)], env=env,
                             stdout=subprocess.PIPE, text=True)
        assert p.stdout.readline().strip() == "compiling"
        time.sleep(3.0)  # the compile of `twice` takes well under a second
        assert p.poll() is None  # waiting for the lock to save its kernel
        assert not list(cache.rglob("*.nbi"))
        fcntl.flock(held, fcntl.LOCK_UN)
    out, _ = p.communicate(timeout=60)
    assert p.returncode == 0 and out.strip() == "42"
    assert len(list(cache.rglob("*.nbi"))) == 1
