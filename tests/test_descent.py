"""The hover-point descent with exact LP hover times (planner_core.descent) and its LP fast path."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.optimize import linprog

from planner_core.construct import candidate_plans
from planner_core.descent import descend, held_points, objective, objective_reference
from planner_core.polish import _lp_matrices, hover_lp
from planner_core.problem import Problem
from tests.conftest import SUITE


@pytest.fixture(scope="module")
def t05() -> Problem:
    return Problem(SUITE / "T05.json")


def _first_plans(problem: Problem, k: int) -> np.ndarray:
    X, _ = candidate_plans(problem, 0, 30)
    f, phi = problem.evaluate(X)
    order = np.lexsort((f, phi))
    return X[order[:k]]


def test_hover_lp_matches_scipy_linprog_on_random_instances() -> None:
    """The warm-started highspy path and scipy's linprog (the polish's reference) agree on the
    LP's value and feasibility; the duals satisfy strong duality where no T_max bound binds."""
    rng = np.random.default_rng(7)
    checked = infeasible = 0
    for _ in range(150):
        n, m = int(rng.integers(1, 12)), int(rng.integers(1, 30))
        R = np.maximum(rng.random((n, m)) * 10.0 - 4.0, 0.0)
        req = rng.random(m) * 200.0 * (rng.random(m) < 0.9)
        got = hover_lp(R, req, 300.0)
        c, G, h, ub = _lp_matrices(R, req, 300.0, True)
        ref = linprog(c, A_ub=G, b_ub=h, bounds=[(0.0, 300.0)] * n, method="highs")
        if got is None:
            assert ref.status == 2  # infeasible both ways
            infeasible += 1
            continue
        assert ref.status == 0
        T, V, y = got
        # the top-up may add a relative ~1e-9 to the LP optimum
        assert V == pytest.approx(ref.fun, rel=1e-6, abs=1e-9)
        assert np.all(R.T @ T >= req - 1e-9 * np.maximum(req, 1.0))
        assert np.all((T >= 0) & (T <= 300.0)) and np.all(y >= 0)
        if np.all(T < 300.0 - 1e-6):
            assert y.sum() == pytest.approx(V, rel=1e-6, abs=1e-9)
        checked += 1
    assert checked > 50 and infeasible > 5


def test_gradient_matches_finite_differences_of_the_reference(t05: Problem) -> None:
    """dF/dP of `objective` against central differences of `objective_reference` (the polish's
    own LP) at the best constructive plans' points, where the LP is non-degenerate."""
    for x in _first_plans(t05, 3):
        P = np.asarray(t05.breakdown(x)["hover_points"])
        F, g, _ = objective(t05, P)
        assert F == pytest.approx(objective_reference(t05, P), rel=1e-9)
        h = 1e-3
        fd = np.zeros_like(P)
        for i in range(P.shape[0]):
            for k in range(2):
                Pp, Pm = P.copy(), P.copy()
                Pp[i, k] += h
                Pm[i, k] -= h
                fd[i, k] = (objective_reference(t05, Pp) - objective_reference(t05, Pm)) / (2 * h)
        assert np.allclose(g, fd, rtol=1e-3, atol=1e-4), np.abs(g - fd).max()


def test_descend_is_feasible_never_worse_counted_and_deterministic(t05: Problem) -> None:
    calls: list[int] = []

    def counted(X: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        calls.append(len(X))
        return t05.evaluate(X)

    improved = 0
    for x in _first_plans(t05, 3):
        f0 = float(t05.evaluate(x[None])[0][0])
        calls.clear()
        r = descend(t05, x, counted, trials=25)
        assert r is not None
        assert r.evaluations == sum(calls) <= 25
        f, phi = t05.evaluate(r.x[None])
        assert phi[0] == 0.0 and f[0] == r.f and r.phi == 0.0
        assert r.f <= f0 + 1e-9
        assert r.f_start == pytest.approx(f0)
        improved += r.f < f0 - 1e-6
        P = np.asarray(t05.breakdown(r.x)["hover_points"])
        assert len(held_points(t05, P)) == 0
        again = descend(t05, x, t05.evaluate, trials=25)
        assert again is not None and again.x.tobytes() == r.x.tobytes()
    assert improved >= 2  # T05's constructive plans are 2-6 % above the best known


def test_descend_refuses_infeasible_plans_and_no_budget(t05: Problem) -> None:
    x = _first_plans(t05, 1)[0]
    assert descend(t05, x, t05.evaluate, trials=0) is None
    bad = x.copy()
    bad[2::4] = 0.0  # no hover time: C4 fails
    assert descend(t05, bad, t05.evaluate, trials=10) is None


def test_plan_with_descent_spends_at_most_the_budget_and_is_not_worse() -> None:
    from lamde_mission.api import plan

    off = plan(SUITE / "T05.json", seed=0, descent=False, budget=3000)
    on = plan(SUITE / "T05.json", seed=0, budget=3000)
    assert on.feasible and off.feasible
    assert on.evaluations <= 3000 and off.evaluations <= 3000
    assert on.f < off.f
