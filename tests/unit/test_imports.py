"""Every module of the package imports on its own, whatever was imported before it.

A cycle between two modules only fails when the import starts at one particular end of it
(materials.params -> case -> case.material -> materials.params failed for the benchmarks, which
import materials.params first, while the CLI, which imports case first, worked). So each module
is imported first, in a process whose impactsim modules are cleared before every import.
"""

import pkgutil
import subprocess
import sys

import impactsim

SCRIPT = """
import importlib, sys, traceback
failed = []
for name in sys.argv[1:]:
    for loaded in [m for m in sys.modules if m == "impactsim" or m.startswith("impactsim.")]:
        del sys.modules[loaded]
    try:
        importlib.import_module(name)
    except Exception:
        failed.append(name + ": " + traceback.format_exc().strip().splitlines()[-1])
print("\\n".join(failed))
sys.exit(1 if failed else 0)
"""


def all_modules():
    return sorted(m.name for m in pkgutil.walk_packages(impactsim.__path__, "impactsim."))


def test_the_walk_finds_the_package():
    names = all_modules()
    assert "impactsim.materials.params" in names and "impactsim.case.material" in names
    assert len(names) > 50


def test_every_module_imports_first():
    proc = subprocess.run([sys.executable, "-c", SCRIPT, *all_modules()],
                          capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stdout + proc.stderr
