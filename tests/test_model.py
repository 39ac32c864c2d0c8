"""planner_core.model.formulas: the paper's formulas once; the compiled scalars equal the
numpy forms."""

from __future__ import annotations

import numpy as np
import pytest

from planner_core.model.formulas import (
    ModelParams,
    deb_best,
    deb_better,
    deb_not_worse,
    flight_time,
    ground_reach,
    leg_time,
    link_rates,
    penalised_score,
    slant_rate,
    slant_rate_grad,
    slant_rates,
)
from planner_core.model.mapio import load_map
from planner_core.model.problem import Problem
from planner_core.model.routing import open_tour
from tests.conftest import SUITE


def test_compiled_leg_time_is_bit_equal_to_flight_time() -> None:
    rng = np.random.default_rng(1)
    d = np.concatenate([[0.0, -3.0, 100.0, 100.0 + 1e-9], rng.uniform(0, 8000, 200)])
    ref = flight_time(d, 20.0, 4.0)
    got = np.array([leg_time(float(x), 20.0, 4.0) for x in d])
    assert np.array_equal(got, ref)
    assert leg_time(-3.0, 20.0, 4.0) == 0.0  # the d >= 0 guard


def test_compiled_slant_rate_is_bit_equal_and_link_rates_clip() -> None:
    rng = np.random.default_rng(2)
    d2 = rng.uniform(0, 2e6, 100)
    ref = slant_rates(d2, 100.0, 10.0, 0.01)
    assert np.array_equal([slant_rate(float(x), 100.0 * 100.0, 10.0, 0.01) for x in d2], ref)
    R = link_rates(np.array([[0.0, 0.0], [2000.0, 0.0]]), np.array([[0.0, 0.0]]), 100.0, 10.0, 0.01)
    assert R[0, 0] == pytest.approx(9.0) and R[1, 0] == 0.0


def test_slant_rate_grad_is_the_rate_and_its_gradient() -> None:
    rng = np.random.default_rng(3)
    h2, peak, decay = 100.0 * 100.0, 10.0, 0.01
    for dx, dy in rng.uniform(-1500.0, 1500.0, (60, 2)):
        rate, gx, gy = slant_rate_grad(float(dx), float(dy), h2, peak, decay)
        # the rate is slant_rate's to the bit
        assert rate == slant_rate(float(dx * dx + dy * dy), h2, peak, decay)
        # the gradient against central differences of the rate (both axes)
        e = 1e-3
        fx = (slant_rate((dx + e) ** 2 + dy * dy, h2, peak, decay)
              - slant_rate((dx - e) ** 2 + dy * dy, h2, peak, decay)) / (2 * e)
        fy = (slant_rate(dx * dx + (dy + e) ** 2, h2, peak, decay)
              - slant_rate(dx * dx + (dy - e) ** 2, h2, peak, decay)) / (2 * e)
        assert gx == pytest.approx(fx, rel=1e-5, abs=1e-9)
        assert gy == pytest.approx(fy, rel=1e-5, abs=1e-9)
    # by hand: 300 m east of the sensor at H = 400 m, r = 500 m: R = 10 - 5, dR/dx = -0.006
    assert slant_rate_grad(300.0, 0.0, 400.0**2, peak, decay) == pytest.approx((5.0, -0.006, 0.0))


def test_deb_rule_and_score() -> None:
    f = np.array([3.0, 1.0, 2.0, 0.5])
    phi = np.array([0.0, 0.0, 1.0, 2.0])
    assert deb_best(f, phi) == 1
    assert list(deb_better(f, phi, np.full(4, 2.0), np.full(4, 0.0))) == [False, True, False, False]
    assert deb_not_worse(2.0, 0.0, 2.0, 0.0) and not deb_better(2.0, 0.0, 2.0, 0.0)
    assert penalised_score(1.0, 2.0) == 21.0


def test_model_params_from_map_match_the_problem() -> None:
    m = load_map(SUITE / "T08.json")
    mp = ModelParams.from_map(m)
    p = Problem(m)
    assert p.model.n_points == mp.n_points == m.max_hover_points
    assert mp.altitude == m.spec.uav.altitude and mp.decay == m.spec.radio.decay
    assert np.array_equal(mp.sensors, m.sensors) and not mp.sensors.flags.writeable
    assert np.array_equal(p.rates(mp.sensors[:2]), mp.rates(mp.sensors[:2]))


@pytest.mark.parametrize("first", [False, True])
def test_open_tour_is_two_opt_optimal(first: bool) -> None:
    rng = np.random.default_rng(3)
    pts = rng.uniform(0, 1000, (12, 2))
    W = np.hypot(*(pts[:, None] - pts[None]).transpose(2, 0, 1))
    t = open_tour(W, first)
    assert t[0] == 0 and t[-1] == 11 and sorted(t.tolist()) == list(range(12))
    for i in range(10):
        for j in range(i + 1, 11):
            g = W[t[i], t[i + 1]] + W[t[j], t[j + 1]] - W[t[i], t[j]] - W[t[i + 1], t[j + 1]]
            assert g <= 1e-6


def test_ground_reach_inverts_the_link_rate() -> None:
    need = np.array([1.0, 5.0, 9.0, 9.5])
    reach = ground_reach(need, 100.0, 10.0, 0.01)
    # at the reach the rate is exactly what was asked for; 9.5 Mbit/s is not even overhead (9.0)
    assert slant_rates(reach[:3] ** 2, 100.0, 10.0, 0.01) == pytest.approx(need[:3])
    assert reach[3] == 0.0
    assert ground_reach(0.0, 100.0, 10.0, 0.0) > 1e12  # no decay: everywhere in range


def test_the_compiled_link_rates_of_one_point_set_are_bit_equal_to_numpy() -> None:
    """`link_rates` takes a compiled loop for one (I, 2) point set; it is bit-equal to the
    broadcast numpy form (the same operations in the same order), which stacked sets use."""
    from planner_core.model.formulas import slant_rates

    rng = np.random.default_rng(7)
    for n, J in ((1, 1), (6, 29), (40, 3)):
        P, S = rng.random((n, 2)) * 1e4, rng.random((J, 2)) * 1e4
        dx = P[:, None, 0] - S[:, 0]
        dy = P[:, None, 1] - S[:, 1]
        want = np.maximum(slant_rates(dx * dx + dy * dy, 100.0, 10.0, 0.01), 0.0)
        assert np.array_equal(link_rates(P, S, 100.0, 10.0, 0.01), want)
        # a stack of point sets (numpy path) row for row the same
        stack = link_rates(np.stack([P, P]), S, 100.0, 10.0, 0.01)
        assert np.array_equal(stack[1], want)
