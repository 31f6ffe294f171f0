"""Make a kernel run the same machine code whether this process compiled it or loaded it from
numba's cache (docs/performance.md, "Whole scenes, session 24").

numba compiles each njit function into a library of its own. A caller links in a copy of each
callee's optimised module, with the callee's functions marked ``linkonce_odr`` (weak), and
LLVM optimises that copy again inside the caller, where, under the kernels' ``contract`` and
``reassoc`` flags, it can round differently from the callee's own code. At run time a call to a
weak symbol goes to the first definition the JIT loaded: in a process that compiled the caller,
the callee's own library, compiled just before it; in a process that loaded the caller from the
cache, the caller's copy (the callee's library is never loaded there). So a run that compiled its
kernels computed other last bits than the same run from the cache, and fracture scenes then
diverged (oblique-sphere: 3,247 steps against 3,045).

``apply()`` gives the copies linked into a library internal linkage before the library is
optimised: every call a kernel makes goes to its own copy, in every process. The callee's own
library, used when Python calls it, is unchanged. Called once, at the package's import, before
any kernel is compiled or loaded; the kernel cache's digest covers this file
(``kernel_cache.kernel_sources``), so kernels cached without it are compiled again.
"""

from __future__ import annotations

_APPLIED = False


def apply() -> None:
    """Patch numba's CPU code library (idempotent)."""
    global _APPLIED
    if _APPLIED:
        return
    import llvmlite.binding as ll
    from numba.core.codegen import CPUCodeLibrary

    optimize = CPUCodeLibrary._optimize_final_module

    def _optimize_final_module(self):
        # called by finalize() right after the linked libraries' modules were linked in: their
        # exported functions are the module's only linkonce_odr definitions
        for fn in self._final_module.functions:
            if not fn.is_declaration and fn.linkage == ll.Linkage.linkonce_odr:
                fn.linkage = "internal"
        optimize(self)

    CPUCodeLibrary._optimize_final_module = _optimize_final_module
    _APPLIED = True
