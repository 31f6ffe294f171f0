"""`make bench` runs every benchmarks/bench_*.py through its main() with no arguments
(benchmarks/run.py), one after the other: one that cannot start that way stops the rest. An A/B
tool that needs a revision or a case (compare.py, step_costs.py) takes another name."""

import importlib
import inspect
import re
import sys
from pathlib import Path

import pytest

BENCH = Path(__file__).resolve().parents[2] / "benchmarks"
NAMES = sorted(p.stem for p in BENCH.glob("bench_*.py"))
POSITIONAL = re.compile(r"add_argument\(\s*['\"][^-]")


def test_the_suite_is_found():
    assert "bench_element" in NAMES and "bench_first_run" in NAMES


@pytest.mark.parametrize("name", NAMES)
def test_a_bench_needs_no_argument(name):
    text = (BENCH / f"{name}.py").read_text()
    assert not POSITIONAL.search(text), f"{name}.py declares a positional argument"
    saved = list(sys.path)  # (bench modules put their folder on the path when imported)
    sys.path.insert(0, str(BENCH.parent))
    try:
        mod = importlib.import_module(f"benchmarks.{name}")
    finally:
        sys.path[:] = saved
    params = inspect.signature(mod.main).parameters.values()
    assert all(p.default is not inspect.Parameter.empty for p in params), \
        f"{name}.main() has a parameter without a default"
