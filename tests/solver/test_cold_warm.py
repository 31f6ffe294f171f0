"""A process that compiles the tet kernel and one that loads it from the cache compute the same
bits (impactsim/numba_linking.py: without it a call went to the callee's own code in the one
and to the caller's copy of it, optimised again, in the other; docs/performance.md, "Whole
scenes, session 24")."""

import pytest

from benchmarks.cold_warm_bits import cold_and_warm


@pytest.mark.slow
@pytest.mark.parametrize("parallel", [False, True], ids=["serial", "threaded"])
def test_compiling_and_loading_processes_agree(parallel):
    cold, warm = cold_and_warm(parallel)
    assert cold and cold == warm


@pytest.mark.slow
def test_a_run_counts_the_kernels_it_compiled(tmp_path):
    """With an empty cache the first run compiles and says how many kernels; the second loads
    them all (summary.json `kernels_compiled`)."""
    import json
    import os
    import subprocess
    import sys
    from pathlib import Path

    from tests.cli.test_run import BAR

    root = Path(__file__).resolve().parents[2]
    case = tmp_path / "bar.toml"
    case.write_text(BAR)
    env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path / "cache"), PYTHONPATH=str(root))
    counts = []
    for k in range(2):
        out = tmp_path / f"out{k}"
        subprocess.run([sys.executable, "-c", "from impactsim.cli import main; main()", "run",
                        str(case), "-o", str(out), "--overwrite", "-q"], env=env, cwd=root,
                       check=True)
        counts.append(json.loads((out / "summary.json").read_text())["kernels_compiled"])
    assert counts[0] > 0 and counts[1] == 0
