"""The error and order-fitting functions of `make accuracy` (benchmarks/accuracy_fit.py) on
synthetic series with a known order, and the report's analysis of a small set of fake runs."""

import math

import pytest

from benchmarks.accuracy_fit import (errors_vs_finest, fit_power, order_vs_finest,
                                     relative_error, richardson_order)


def test_relative_error():
    assert relative_error(1.1, 1.0) == pytest.approx(0.1)
    assert relative_error(0.9, -1.0) == pytest.approx(1.9)
    assert relative_error(-2e-6, 0.0) == pytest.approx(2e-6)  # exact 0: absolute


def test_fit_power_recovers_order_and_constant():
    h = [0.4, 0.2, 0.1, 0.05]
    err = [3.0 * x ** 1.5 for x in h]
    p, c = fit_power(h, err)
    assert p == pytest.approx(1.5)
    assert c == pytest.approx(3.0)
    # zero and non-finite errors are left out; too few points give None
    assert fit_power([0.4, 0.2, 0.1], [0.0, 0.2, math.nan]) is None
    assert fit_power([0.1, 0.1], [0.2, 0.3]) is None


@pytest.mark.parametrize("p", [1.0, 2.0, 0.6])
def test_richardson_order_equal_ratios(p):
    h = [0.8, 0.4, 0.2, 0.1]
    f = [16.0 + 2.5 * x ** p for x in h]
    got, extrapolated = richardson_order(h, f)
    assert got == pytest.approx(p, rel=1e-8)
    assert extrapolated == pytest.approx(16.0, rel=1e-10)


def test_richardson_order_unequal_ratios():
    h = [1.6, 1.0, 0.7, 0.4]  # r21 = 1.75, r32 = 1.43
    f = [5.0 - 0.3 * x ** 1.7 for x in h]
    got, extrapolated = richardson_order(h, f)
    assert got == pytest.approx(1.7, rel=1e-6)
    assert extrapolated == pytest.approx(5.0, rel=1e-8)


def test_richardson_order_oscillating_or_flat_is_none():
    assert richardson_order([0.4, 0.2, 0.1], [1.0, 1.2, 1.1]) is None
    assert richardson_order([0.4, 0.2, 0.1], [1.0, 1.0, 1.0]) is None
    assert richardson_order([0.2, 0.1], [1.0, 1.1]) is None


def test_order_vs_finest():
    h = [0.8, 0.4, 0.2, 0.1, 0.025]
    f = [10.0 * (1.0 + x ** 2) for x in h]
    errs = errors_vs_finest(f)
    assert errs[-1] == 0.0
    assert errs[0] == pytest.approx((0.64 - 0.025 ** 2) / (1 + 0.025 ** 2))
    p, _ = order_vs_finest(h, f)
    # the finest run stands in for the limit: close to 2, a little high (the differences shrink
    # faster than the errors as the runs near the finest)
    assert 2.0 <= p < 2.1


def test_analyse_study_from_fake_runs(tmp_path):
    from benchmarks.accuracy_report import analyse, runs_table
    from benchmarks.accuracy_studies import Level, Study

    study = Study("fake", "Fake", tmp_path / "x.toml", "bar_column", "", {"tet4": []},
                  [Level(h, [], f"{h}") for h in (0.4, 0.2, 0.1, 0.05)])
    runs = []
    for i, h in enumerate((0.4, 0.2, 0.1, 0.05)):
        runs.append({"study": "fake", "series": "tet4", "level": i, "x": h, "label": str(h),
                     "elements": int(6 / h ** 3), "steps": int(10 / h),
                     "wall_seconds": 1e-3 / h ** 4, "stopped": None,
                     "quantities": {
                         "a": {"value": 2.0 + 0.5 * h, "exact": 2.0, "theory": None,
                               "unit": "", "scale": 1.0},
                         "b": {"value": 7.0 + h ** 2, "exact": None, "theory": 7.0,
                               "unit": "mm", "scale": 1e3}}})
    columns, fits = analyse(study, runs)
    a = next(c for c in columns if c.quantity == "a")
    assert a.reference == "exact"
    assert a.order == pytest.approx(1.0)
    assert a.rate == pytest.approx(0.25)  # wall ~ h^-4
    b = next(c for c in columns if c.quantity == "b")
    assert b.reference == "finest" and 2.0 < b.order < 2.3
    fb = next(f for f in fits if f.quantity == "b")
    assert fb.richardson[0] == pytest.approx(2.0)
    table = runs_table(study, runs, columns)
    assert len(table) == 2 + len(runs) and "(ref.)" in table[-1]
