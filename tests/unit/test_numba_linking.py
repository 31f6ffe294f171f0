"""impactsim/numba_linking.py is applied before any kernel is compiled or loaded, whichever of
numba and impactsim a process imports first, and only once numba's code generator loads (so a
command that runs no kernel does not import numba). That the patch makes a compiling and a
loading process compute the same bits is tests/solver/test_cold_warm.py's (slow tier)."""

import math
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]

CHECK = """
import sys
{first}
from impactsim import numba_linking
loaded = "numba" in sys.modules
import numba
from numba.core.codegen import CPUCodeLibrary
patched = CPUCodeLibrary._finalize_final_module.__module__ == "impactsim.numba_linking"
print(loaded, numba_linking._APPLIED, patched)
"""


@pytest.mark.parametrize("first, numba_loaded", [("import impactsim", "False"),
                                                 ("import numba", "True")],
                         ids=["impactsim-first", "numba-first"])
def test_patch_applied_when_numba_loads(first, numba_loaded):
    out = subprocess.run([sys.executable, "-c", CHECK.format(first=first)], cwd=ROOT,
                         capture_output=True, text=True, check=True).stdout.split()
    assert out == [numba_loaded, "True", "True"]


def test_linked_copies_are_internal_and_shared_weak():
    """A kernel's library holds its callee as an internal copy; the module it gives its own
    callers holds that copy weak again (linkonce_odr), as numba made it."""
    import llvmlite.binding as ll
    import numba

    from impactsim import numba_linking

    @numba.njit
    def callee(a):  # calls enough to stay a function of its own after the optimisation
        s = 0.0
        for k in range(int(a)):
            s += (math.sin(s + k) + math.cos(s * k) + math.exp(-s) + math.log1p(k) + math.tan(s)
                  + math.atan(s + 1.0) + math.sinh(0.1 * s) + math.cosh(0.1 * k)
                  + math.asinh(s) + math.erf(s) + math.erfc(k) + math.gamma(1.5 + k % 3))
        return s

    @numba.njit
    def caller(a):
        return callee(a) - callee(a + 1.0)

    assert math.isfinite(caller(3.0))
    assert numba_linking._APPLIED
    lib = caller.overloads[caller.signatures[0]].library
    name = callee.overloads[callee.signatures[0]].fndesc.llvm_func_name
    assert lib._final_module.get_function(name).linkage == ll.Linkage.internal
    assert lib._get_module_for_linking().get_function(name).linkage == ll.Linkage.linkonce_odr
