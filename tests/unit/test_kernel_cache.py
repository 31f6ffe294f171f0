"""The kernel-cache guard: cached kernels go when a source a kernel can depend on changed."""

from impactsim.kernel_cache import cached_kernels, refresh, source_digest


def _package(tmp_path):
    pkg = tmp_path / "pkg"
    (pkg / "solver" / "__pycache__").mkdir(parents=True)
    (pkg / "solver" / "element.py").write_text("import numba\njc = numba.njit(lambda: 1)\n")
    (pkg / "solver" / "hex8.py").write_text("import numba\nfrom impactsim.solver.element import jc\n"
                                            "from impactsim.model import ERODED\n")
    (pkg / "model.py").write_text("ERODED = 3\n")  # a constant numba freezes into a kernel
    (pkg / "cli.py").write_text("import click\n")  # no kernel depends on it
    for name in ("hex8.kernel-1.py311.nbi", "hex8.kernel-1.py311.1.nbc"):
        (pkg / "solver" / "__pycache__" / name).write_bytes(b"old machine code")
    return pkg


def test_a_callee_edit_clears_the_caller_kernels(tmp_path):
    pkg = _package(tmp_path)
    assert refresh(pkg) == 2  # a cache of unknown age is treated as stale
    (pkg / "solver" / "__pycache__" / "hex8.kernel-1.py311.nbi").write_bytes(b"new code")
    assert refresh(pkg) == 0  # sources unchanged: the cache stays
    assert len(cached_kernels(pkg)) == 1
    before = source_digest(pkg)
    (pkg / "cli.py").write_text("import click  # edited\n")
    assert source_digest(pkg) == before  # no kernel reads the CLI: the cache stays
    (pkg / "model.py").write_text("ERODED = 4\n")
    assert source_digest(pkg) != before
    before = source_digest(pkg)
    (pkg / "solver" / "element.py").write_text("import numba\njc = numba.njit(lambda: 2)\n")
    assert source_digest(pkg) != before
    assert refresh(pkg) == 1 and cached_kernels(pkg) == []
    assert refresh(pkg) == 0


def test_a_renamed_file_changes_the_digest(tmp_path):
    pkg = _package(tmp_path)
    before = source_digest(pkg)
    (pkg / "solver" / "hex8.py").rename(pkg / "solver" / "hex9.py")
    assert source_digest(pkg) != before
