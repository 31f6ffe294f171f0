"""Ballistic limit: the bisection (k-section) converges to a known threshold within the
tolerance, with a stand-in criterion and on real runs of a cheap monotone scene."""

import math

import numpy as np
import pandas as pd
import pytest

from impactsim.studies import ballistic as B
from tests.studies.test_sweep import BAR


def _standin(thresholds, calls):
    def evaluate(points):
        calls.append(len(points))
        return [x > thresholds[c] for c, x in points]
    return evaluate


@pytest.mark.parametrize("width", [1, 2, 5])
def test_search_brackets_the_threshold_within_tolerance(width):
    thr = [0.3141, 0.5, 0.7777]
    calls = []
    st = B.search(_standin(thr, calls), 3, 0.1, 0.9, 1e-3, width)
    for s, t in zip(st, thr):
        assert s["status"] == "ok"
        assert s["lo"] <= t <= s["hi"] and s["hi"] - s["lo"] <= 1e-3
        assert abs(s["limit"] - t) <= 0.5e-3
    if width == 1:  # bisection: log2(0.8 / 1e-3) = 9.6 -> 10 rounds after the two ends
        assert st[0]["runs"] == 2 + 10


def test_search_falling_criterion_and_unbracketed():
    # perforated at low values (a thicker plate stops it): the sense is found from the ends
    st = B.search(lambda pts: [x < 0.4 if c == 0 else True for c, x in pts], 2, 0.0, 1.0, 0.01)
    assert st[0]["status"] == "ok" and abs(st[0]["limit"] - 0.4) <= 0.005
    assert st[1]["status"] == "perforated over the whole range" and math.isnan(st[1]["limit"])
    st = B.search(lambda pts: [None for _ in pts], 1, 0.0, 1.0, 0.01)
    assert st[0]["status"] == "failed run"


def test_ballistic_limit_on_runs_of_a_bar_rebounding_from_a_wall(tmp_path):
    """The elastic bar leaves the wall with a fixed fraction r of its impact speed (linear
    elasticity), so 'residual speed above 30 m/s' switches at 30 / r."""
    case = tmp_path / "bar.toml"
    case.write_text(BAR)
    ref = tmp_path / "ref.csv"
    ref.write_text("cfl,speed\n0.5,33\n0.6,33\n")
    crit = B.Criterion("residual", "bar", 30.0)
    curve, folder = B.ballistic_limit(case, "body.bar.speed", "20 m/s", "60 m/s", "run.cfl",
                                      [0.5, 0.6], "0.5 m/s", crit, tmp_path / "bl", workers=0,
                                      reference=ref, say=lambda s: None)
    runs = pd.read_csv(folder / "runs.csv")
    for cfl, limit in zip(curve["run.cfl"], curve["body.bar.speed limit [m/s]"]):
        r = runs[(runs["run.cfl"] == cfl) & (runs["body.bar.speed"] == 20.0)]
        ratio = float(r["bar.mean_velocity_z [m/s]"].iloc[0]) / 20.0
        assert 0.8 < ratio < 1.0
        assert abs(limit - 30.0 / ratio) <= 0.25 + 1e-9  # half the tolerance
    assert (curve["status"] == "ok").all()
    assert (folder / "ballistic.png").stat().st_size > 10_000
    # a second call runs nothing new: every run finished earlier
    again, _ = B.ballistic_limit(case, "body.bar.speed", "20 m/s", "60 m/s", "run.cfl",
                                 [0.5, 0.6], "0.5 m/s", crit, tmp_path / "bl", workers=0,
                                 say=lambda s: None)
    np.testing.assert_array_equal(again.iloc[:, 1], curve.iloc[:, 1])


def test_default_criterion_is_the_last_plate(tmp_path):
    raw = {"body": [{"name": "front", "shape": "plate"}, {"name": "s", "shape": "sphere"},
                    {"name": "rear", "shape": "plate"}]}
    assert B.resolve_criterion(B.Criterion(), raw, "c.toml").body == "rear"
    with pytest.raises(B.SweepError, match="no body 'x'"):
        B.resolve_criterion(B.Criterion("hole", "x"), raw, "c.toml")
    assert B.Criterion("hole", "rear").perforated({"status": "ok", "rear.perforated": True})
    assert B.Criterion("hole", "rear").perforated({"status": "failed"}) is None


def test_cli_errors_are_one_line(tmp_path):
    from click.testing import CliRunner

    from impactsim.cli import main

    bad = tmp_path / "bad.toml"
    bad.write_text("[run]\nname = 1\nname = 2\n")
    r = CliRunner().invoke(main, ["ballistic-limit", str(bad), "--vary", "body.0.radius",
                                  "--range", "1 mm", "2 mm", "--at", "run.cfl=0.5",
                                  "--tol", "0.1 mm"])
    assert r.exit_code == 2 and "invalid TOML" in r.output and "Traceback" not in r.output
    case = tmp_path / "bar.toml"
    case.write_text(BAR)
    r = CliRunner().invoke(main, ["ballistic-limit", str(case), "--vary", "body.bar.speed",
                                  "--range", "1 mm", "2 m/s", "--at", "run.cfl=0.5",
                                  "--tol", "0.1"])
    assert r.exit_code == 2 and "one unit" in r.output
    r = CliRunner().invoke(main, ["ballistic-limit", str(case), "--vary", "body.bar.speed",
                                  "--range", "1", "2", "--at", "run.cfl=0.5", "--tol", "0.1"])
    assert r.exit_code == 2 and "no body of shape 'plate'" in r.output


@pytest.mark.slow
def test_hole_criterion_on_a_coarse_sphere_through_a_plate(tmp_path):
    """The default criterion (a hole through the case's plate) on real fracture runs: the
    bracket's ends disagree, every run below the limit left the plate whole and every run above
    perforated it."""
    from tests.solver.test_checkpoint import PLATE

    case = tmp_path / "sp.toml"
    # [D19]'s spall (instantaneous, on the cell's own pressure), as the bundled sphere-plate
    # scenes: under the defaults this plate stays whole at 1 km/s over the whole radius range
    case.write_text(PLATE.replace('checkpoint_every = "0.7 us"', "history_every = 5")
                    .replace('end_time = "3 us"', 'end_time = "4 us"')
                    .replace("[fracture]\n", '[fracture]\nspall_criterion = "instant"\n'
                             'spall_pressure = "cell"\n'))
    curve, folder = B.ballistic_limit(case, "body.sphere.radius", "1 mm", "4 mm",
                                      "body.sphere.speed", ["1 km/s"], "0.5 mm", None,
                                      tmp_path / "bl", workers=0, say=lambda s: None)
    assert curve["status"].iloc[0] == "ok"
    limit = curve.iloc[0, 1]
    runs = pd.read_csv(folder / "runs.csv")
    r = runs["body.sphere.radius"]
    assert runs[r < limit]["plate.perforated"].eq(False).all()
    assert runs[r > limit]["plate.perforated"].eq(True).all()
