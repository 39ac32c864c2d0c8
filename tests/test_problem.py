"""The paper's model pinned on a map small enough to compute by hand."""

from __future__ import annotations

import math

import numpy as np
import pytest

from planner_core import Problem, flight_time, load_map, penalised_score


def _x(problem: Problem, second_eps: float = 0.2) -> np.ndarray:
    # slot 1: hover 50 s at (300, 0); slot 2: (900, 900), 40 s, active iff eps >= tau
    return np.array([300, 0, 50, 0.9, 900, 900, 40, second_eps], dtype=float)


def test_flight_time_trapezoid_and_triangle() -> None:
    # v = 20, a = 4: v^2/a = 100 m separates the two cases, which meet continuously there
    assert flight_time(np.array(500.0), 20, 4) == pytest.approx(500 / 20 + 20 / 4)
    assert flight_time(np.array(64.0), 20, 4) == pytest.approx(2 * math.sqrt(64 / 4))
    assert flight_time(np.array(100.0), 20, 4) == pytest.approx(10.0)
    assert flight_time(np.array(100.0 + 1e-9), 20, 4) == pytest.approx(10.0)
    assert flight_time(np.array(0.0), 20, 4) == 0.0


def test_hand_computed_terms(hand_map: dict) -> None:
    p = Problem(hand_map)
    assert p.dim == 8
    np.testing.assert_array_equal(p.upper, [1000, 1000, 300, 1, 1000, 1000, 300, 1])
    b = p.breakdown(_x(p))
    # legs 300 m and 400 m, both in the cruise regime: 300/20+5 and 400/20+5
    assert b["t_fly"] == pytest.approx(45.0)
    assert b["t_hover"] == pytest.approx(50.0)
    assert b["f"] == pytest.approx(0.5 * 45 + 0.5 * 50)
    r_a = 10 - 0.01 * 100.0
    r_b = 10 - 0.01 * math.sqrt(300**2 + 100**2)
    assert b["collected"]["a"] == pytest.approx(r_a * 50)
    assert b["collected"]["b"] == pytest.approx(r_b * 50)
    # C3: bandwidth 15 < r_a + r_b; C4: b needs 400 Mbit
    assert b["v3"] == pytest.approx(r_a + r_b - 15)
    assert b["v4"] == pytest.approx(400 - r_b * 50)
    assert b["v5"] == 0.0 and b["l_vio"] == 0.0
    assert b["phi"] == pytest.approx(b["v3"] + b["v4"])
    assert b["n_hover"] == 1
    assert b["hover_points"] == [[300.0, 0.0]]
    f, phi = p.evaluate(_x(p)[None, :])
    assert f[0] == pytest.approx(b["f"]) and phi[0] == pytest.approx(b["phi"])
    assert b["score"] == pytest.approx(penalised_score(b["f"], b["phi"]))


def test_activation_threshold_and_fixed_length(hand_map: dict) -> None:
    p = Problem(hand_map)
    x = _x(p, second_eps=0.5)  # eps == tau is active
    b = p.breakdown(x)
    assert b["n_hover"] == 2
    d2 = math.hypot(600, 900)
    d3 = math.hypot(600, 500)
    assert b["t_fly"] == pytest.approx(20 + (d2 / 20 + 5) + (d3 / 20 + 5))
    fixed = Problem(hand_map, variable_length=False)
    assert fixed.breakdown(_x(fixed, second_eps=0.0))["n_hover"] == 2


def test_collision_penalty(hand_map: dict) -> None:
    hand_map["obstacles"] = {"circles": [{"x": 150, "y": 0, "radius": 50}]}
    p = Problem(hand_map)
    b = p.breakdown(_x(p))
    assert b["l_vio"] == pytest.approx(100.0)
    assert b["v5"] == pytest.approx(1000 + 10 * 100.0)


def test_population_matches_single_breakdowns(hand_map: dict) -> None:
    hand_map["obstacles"] = {
        "circles": [{"x": 500, "y": 500, "radius": 80}],
        "rectangles": [{"x": 200, "y": 700, "length": 150, "width": 90, "angle_deg": 30}],
        "no_fly_zones": [{"vertices": [[700, 100], [950, 150], [800, 350]]}],
    }
    p = Problem(hand_map)
    rng = np.random.default_rng(3)
    X = p.lower + rng.random((64, p.dim)) * (p.upper - p.lower)
    f, phi = p.evaluate(X)
    for i in range(0, 64, 7):
        b = p.breakdown(X[i])
        assert f[i] == pytest.approx(b["f"], rel=1e-12)
        assert phi[i] == pytest.approx(b["phi"], rel=1e-12)


def test_out_of_bounds_values_are_clamped(hand_map: dict) -> None:
    p = Problem(hand_map)
    x = _x(p)
    y = x.copy()
    y[2] = 1e6  # hover time beyond T_max counts as T_max
    y[0] = -50  # x below 0 counts as 0
    b = p.breakdown(y)
    assert b["hover_times"] == [300.0]
    assert b["hover_points"] == [[0.0, 0.0]]


@pytest.mark.parametrize("variable", [True, False])
@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
def test_a_non_finite_vector_is_never_feasible(hand_map: dict, variable: bool,
                                               bad: float) -> None:
    """A row with a NaN (or +-inf) entry read as feasible: on small-demo.json X[1, 0] = nan gave
    f = nan, phi = 0.0, and on T01 `evaluate` said phi 0 where `breakdown` said nan. Now f and
    phi are inf in both, for any entry of any row (a hover coordinate, a time, an activation
    gene), and the other rows of the population are evaluated as alone."""
    from tests.conftest import ROOT

    maps = [hand_map, ROOT / "examples" / "maps" / "small-demo.json",
            ROOT / "examples" / "maps" / "suite" / "T01.json"]
    for m in maps:
        p = Problem(m, variable_length=variable)
        rng = np.random.default_rng(0)
        X = p.lower + rng.random((4, p.dim)) * (p.upper - p.lower)
        f0, phi0 = p.evaluate(X)
        for j in (0, 2, 3, p.dim - 1):
            Y = X.copy()
            Y[1, j] = bad
            f, phi = p.evaluate(Y)
            assert f[1] == np.inf and phi[1] == np.inf, (m, j)
            keep = [0, 2, 3]
            np.testing.assert_array_equal(f[keep], f0[keep])
            np.testing.assert_array_equal(phi[keep], phi0[keep])
            b = p.breakdown(Y[1])
            assert (b["f"], b["phi"], b["score"]) == (np.inf, np.inf, np.inf), (m, j)
        assert np.all(np.isfinite(X))  # the caller's array is not touched
        Y = X.copy()
        Y[1, :2] = 1e308  # finite, clipped to the box as ever (though their sum overflows)
        f, phi = p.evaluate(Y)
        assert np.isfinite(f[1]) and np.isfinite(phi[1])
        assert (f[1], phi[1]) == p.evaluate(np.clip(Y[1], p.lower, p.upper)[None, :])


def test_encode_round_trip(hand_map: dict) -> None:
    p = Problem(hand_map)
    x = p.encode([[300, 0]], [50])
    b = p.breakdown(x)
    assert b["hover_points"] == [[300.0, 0.0]] and b["hover_times"] == [50.0]
    with pytest.raises(ValueError):
        p.encode([[1, 1]] * 3, [1, 1, 1])


def test_encode_needs_one_hover_time_per_point(hand_map: dict) -> None:
    """A single time was broadcast to every point and another wrong count failed with numpy's
    broadcast message; both are one ValueError naming hover_times (no caller relies on the
    broadcast)."""
    p = Problem(hand_map)
    assert p.n_points >= 2
    for times in ([50.0], [50.0, 60.0, 70.0], []):
        n = f"{len(times)} value" + ("" if len(times) == 1 else "s")
        with pytest.raises(ValueError, match=rf"^hover_times: {n} for 2 hover points; give one "
                           r"per point$"):
            p.encode([[300, 0], [400, 0]], times)
    assert p.breakdown(p.encode([[300, 0], [400, 0]], [50.0, 60.0]))["hover_times"] == [50.0,
                                                                                        60.0]


def test_problem_accepts_map_path_and_value(tmp_path, hand_map: dict) -> None:
    import json

    path = tmp_path / "m.json"
    path.write_text(json.dumps(hand_map))
    m = load_map(path)
    assert Problem(path).dim == Problem(m).dim == Problem(hand_map).dim


@pytest.mark.parametrize("variable", [True, False])
def test_compiled_path_matches_numpy_reference(variable: bool) -> None:
    from tests.conftest import SUITE

    p = Problem(load_map(SUITE / "T16.json"), variable_length=variable)
    rng = np.random.default_rng(11)
    span = p.upper - p.lower
    X = p.lower - 0.05 * span + rng.random((300, p.dim)) * 1.1 * span  # some out of bounds
    f, phi = p.evaluate(X)
    parts = p._evaluate_parts(X)
    np.testing.assert_allclose(f, parts["f"], rtol=1e-12)
    np.testing.assert_allclose(phi, parts["phi"], rtol=1e-12, atol=1e-9)
    assert np.any(phi == 0) or np.any(parts["l_vio"] > 0)


def test_evaluate_rejects_wrong_shape(hand_map: dict) -> None:
    p = Problem(hand_map)
    with pytest.raises(ValueError, match="X: expected shape"):
        p.evaluate(np.zeros((3, p.dim + 1)))
