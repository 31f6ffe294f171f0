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

``apply()`` gives those copies internal linkage when the optimised library is handed to the
JIT, after the optimisation: every call a kernel makes goes to its own copy, in every process,
and the copies are optimised as before (internal from the start, LLVM inlined the single-use
ones into their callers, and the elastic tet kernel took 50-54 ns instead of 45). The module
other libraries link (numba's ``_get_module_for_linking``) keeps them ``linkonce_odr``, as
before. A callee's own library, used when Python calls it, is unchanged.

``install()``, at the package's import, applies it as soon as numba's code generator is loaded,
before any kernel is compiled or loaded, and not before: the commands that run no kernel
(`impactsim --help`: 0.05 s against 0.31 with the code generator imported) do not import numba.
The kernel cache's digest covers this file (``kernel_cache.kernel_sources``), so kernels cached
without the patch are compiled again.
"""

from __future__ import annotations

import importlib.abc
import importlib.util
import sys

_APPLIED = False
_CODEGEN = "numba.core.codegen"


def install() -> None:
    """``apply()`` now if numba's code generator is loaded, else right after it loads."""
    if _CODEGEN in sys.modules:
        apply()
    elif not any(isinstance(f, _AfterCodegen) for f in sys.meta_path):
        sys.meta_path.insert(0, _AfterCodegen())


class _AfterCodegen(importlib.abc.MetaPathFinder):
    """Finds numba's code generator with the other finders and has it patched once loaded."""

    def find_spec(self, fullname, path, target=None):
        if fullname != _CODEGEN:
            return None
        sys.meta_path.remove(self)
        spec = importlib.util.find_spec(fullname)
        if spec is not None and spec.loader is not None:
            spec.loader = _PatchingLoader(spec.loader)
        return spec


class _PatchingLoader(importlib.abc.Loader):
    """The code generator's own loader, then ``apply()``."""

    def __init__(self, loader):
        self._loader = loader

    def create_module(self, spec):
        return self._loader.create_module(spec)

    def exec_module(self, module):
        self._loader.exec_module(module)
        apply()

    def __getattr__(self, name):  # get_source, get_filename ... of the loader it wraps
        return getattr(self._loader, name)


def apply() -> None:
    """Patch numba's CPU code library (idempotent)."""
    global _APPLIED
    if _APPLIED:
        return
    import llvmlite.binding as ll
    from numba.core.codegen import CPUCodeLibrary

    finalize_module = getattr(CPUCodeLibrary, "_finalize_final_module", None)
    module_for_linking = getattr(CPUCodeLibrary, "_get_module_for_linking", None)
    if finalize_module is None or module_for_linking is None or not hasattr(ll, "Linkage"):
        # a numba whose internals moved: leave it as it is (runs still work; a compiling and
        # a cached run may then differ in the last bits, and tests/unit/test_numba_linking.py
        # fails to say so)
        return

    def _finalize_final_module(self):
        # called once the linked libraries' modules were linked in and the whole optimised
        # (finalize), or on a library loaded from the cache (no functions then): the module's
        # linkonce_odr definitions are the copies linked in
        mod = self._final_module
        copies = [fn.name for fn in mod.functions
                  if not fn.is_declaration and fn.linkage == ll.Linkage.linkonce_odr]
        for name in copies:
            mod.get_function(name).linkage = "internal"
        self._internal_copies = set(copies)
        finalize_module(self)

    def _get_module_for_linking(self):
        copies = getattr(self, "_internal_copies", None)
        if copies and self._shared_module is None:  # numba's, with the copies weak again
            self._ensure_finalized()
            mod = self._final_module.clone()
            for fn in mod.functions:
                if not fn.is_declaration and (fn.linkage == ll.Linkage.external
                                              or fn.name in copies):
                    fn.linkage = "linkonce_odr"
            self._shared_module = mod
        return module_for_linking(self)

    CPUCodeLibrary._finalize_final_module = _finalize_final_module
    CPUCodeLibrary._get_module_for_linking = _get_module_for_linking
    _APPLIED = True
