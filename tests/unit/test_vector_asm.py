"""The tet kernel's lane loops compile to packed vector code with AVX2 alone (issue 14: the
machines here are not all alike, and an AVX2-only Zen 3 must get the vector path too).

A fresh process compiles the loops for a Haswell (AVX2 + FMA, no AVX-512: `NUMBA_CPU_NAME`)
into an empty numba cache and counts in each loop's assembly the packed double instructions
on 256-bit registers; no 512-bit register may appear.
"""

import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]

SCRIPT = r"""
import json, re
import numpy as np
from impactsim.solver import element as E

buf = np.ones(E.TET_ROWS * E.B)
E._kinematics_block(buf, 1e-9, 2e-9, 4e10)
for stat in (None, True):
    E._pressure_block(buf, 1e-9, False, 1, 8900.0, 1.4e11, 3900.0, 1.5, 2.0, 4.6e10, 1.2, 0.06,
                      stat)
E._jc_start(buf, 90e6, 0.31, 0.025, 1.4e11, 1.0)
E._jc_newton(buf, 90e6, 292e6, 0.31, 1.4e11)
E._jc_finish(buf, 1e-7, 293.0, 1e-3, 1.09)
out = {}
for f in (E._kinematics_block, E._pressure_block, E._jc_start, E._jc_newton, E._jc_finish):
    for k, sig in enumerate(f.signatures):
        asm = f.inspect_asm(sig)
        out[f"{f.__name__}[{k}]"] = (len(re.findall(r"\bv\w+pd\s[^\n]*%ymm", asm)),
                                     len(re.findall(r"%zmm", asm)))
print(json.dumps(out))
"""


@pytest.mark.slow
def test_lane_loops_are_packed_with_avx2_alone():
    with tempfile.TemporaryDirectory() as cache:
        env = dict(os.environ, NUMBA_CACHE_DIR=cache, NUMBA_CPU_NAME="haswell",
                   NUMBA_CPU_FEATURES="", PYTHONPATH=str(ROOT), NUMBA_NUM_THREADS="1")
        res = subprocess.run([sys.executable, "-c", SCRIPT], cwd=ROOT, env=env, check=True,
                             capture_output=True, text=True)
    counts = json.loads(res.stdout.strip().splitlines()[-1])
    assert len(counts) == 6  # both _pressure_block specialisations
    for name, (packed, zmm) in counts.items():
        assert zmm == 0, name
        assert packed > 40, (name, packed)  # packed 4-wide double arithmetic
