"""impactsim asks OpenMP for passive waiting at a barrier (impactsim/__init__.py), unless the
user chose a policy: the threads of numba's parallel kernels then sleep instead of spinning
while the other thread finishes, which on a shared machine is what lets it finish."""

import os
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
_SHOW = "import impactsim, os; print(os.environ['OMP_WAIT_POLICY'])"


def _policy(env_value):
    env = {k: v for k, v in os.environ.items() if k != "OMP_WAIT_POLICY"}
    env["PYTHONPATH"] = str(ROOT)
    if env_value is not None:
        env["OMP_WAIT_POLICY"] = env_value
    return subprocess.run([sys.executable, "-c", _SHOW], env=env, check=True,
                          capture_output=True, text=True).stdout.strip()


def test_passive_by_default_and_the_users_choice_kept():
    assert _policy(None) == "PASSIVE"
    assert _policy("ACTIVE") == "ACTIVE"
