"""The lower bound: exact on maps solved by hand, below every suite witness, cache consistent."""

from __future__ import annotations

import copy
import json
from pathlib import Path

import numpy as np
import pytest

from planner_core.bench.limits import file_sha256, lower_bounds_path, suite_task_files
from planner_core.model.bounds import lower_bound
from planner_core.model.formulas import flight_time
from planner_core.model.problem import Problem
from tests.conftest import SUITE

CACHE = lower_bounds_path(SUITE)

ONE = {
    "name": "one",
    "area": {"width": 1000, "height": 800},
    "start": [0, 0],
    "end": [900, 700],
    "sensors": [{"id": "a", "x": 333.3, "y": 412.9}],
}


def _suite_files() -> dict[str, Path]:
    if not SUITE.is_dir():
        pytest.skip("suite maps not generated")
    files = suite_task_files(SUITE)
    if not files:
        pytest.skip("suite maps not generated")
    return files


def _cache() -> dict:
    if not CACHE.exists():
        pytest.skip(f"{CACHE} not generated")
    return json.loads(CACHE.read_text())["tasks"]


def _witness_f(path: Path) -> float:
    p = Problem(path)
    w = p.map.spec.witness
    f, phi = p.evaluate(p.encode(w.hover_points, w.hover_times)[None, :])
    assert phi[0] == 0.0
    return float(f[0])


def test_one_sensor_by_hand() -> None:
    # best hover: right above the sensor, rate R_c - xi * H = 10 - 0.01 * 100 = 9 Mbit/s
    lb = lower_bound(ONE)
    assert lb.hover_lb == pytest.approx(200.0 / 9.0, rel=1e-6)
    fly = float(flight_time(np.hypot(900, 700), 20.0, 4.0))
    assert lb.flight_lb == pytest.approx(fly)
    assert lb.lb == pytest.approx(0.5 * fly + 0.5 * 200.0 / 9.0, rel=1e-6)
    assert lb.spacing <= 25.0 and lb.status == "optimal"


def test_shared_hover_point_serves_both() -> None:
    # two sensors on one spot: one hover point serves both at 9 Mbit/s each
    m = copy.deepcopy(ONE)
    m["sensors"].append({"id": "b", "x": 333.3, "y": 412.9, "required_data": 100})
    assert lower_bound(m).hover_lb == pytest.approx(200.0 / 9.0, rel=1e-6)


def test_unreachable_sensor_gives_infinite_bound() -> None:
    m = copy.deepcopy(ONE)
    m["radio"] = {"peak_rate": 0.5}  # R_c / xi = 50 m < H: no rate anywhere
    lb = lower_bound(m)
    assert lb.lb == np.inf and lb.status.startswith("infeasible")


def test_lb_below_plans_on_a_small_map() -> None:
    # any plan's f is at least LB: try the optimum-ish plan (hover right above the sensor)
    p = Problem(ONE)
    lb = lower_bound(ONE).lb
    f, phi = p.evaluate(p.encode([[333.3, 412.9]], [200.0 / 9.0 + 1e-6])[None, :])
    assert phi[0] == 0.0 and lb <= f[0]


def test_cache_matches_the_suite_and_lb_below_every_witness() -> None:
    files = _suite_files()
    cache = _cache()
    for name, path in files.items():
        e = cache.get(name)
        assert e is not None, f"{name} missing from {CACHE}"
        assert e["sha256"] == file_sha256(path), f"{CACHE} is stale for {name}"
        assert e["status"] == "optimal"
        assert 0.0 < e["lb"] < _witness_f(path), name


@pytest.mark.parametrize("name", ["T01", "T07"])
def test_cache_values_recomputed(name: str) -> None:
    files = _suite_files()
    e = _cache()[name]
    lb = lower_bound(files[name])
    assert lb.lb == pytest.approx(e["lb"], rel=1e-6)
    assert lb.n_candidates == e["n_candidates"]


@pytest.mark.slow
def test_every_suite_lb_recomputed() -> None:
    files = _suite_files()
    cache = _cache()
    for name, path in files.items():
        lb = lower_bound(path)
        assert lb.lb == pytest.approx(cache[name]["lb"], rel=1e-6), name
        assert lb.lb < _witness_f(path), name
