"""The memetic step (issue 14): structural moves + exact LP hover times for the elite."""

from __future__ import annotations

from functools import partial

import numpy as np
import pytest

from planner_core.baselines import BudgetedProblem
from planner_core.de import run
from planner_core.de.core import init, to_problem
from planner_core.de.memetic import memetic_step
from planner_core.memetic import refine, two_opt_order
from planner_core.problem import Problem
from tests.test_baselines import SMALL_MAP


@pytest.fixture(scope="module")
def problem() -> Problem:
    return Problem(SMALL_MAP)


def test_two_opt_untangles_a_crossed_route(problem: Problem) -> None:
    # start (50, 50) -> end (1150, 950): visiting the far point first crosses the route
    pts = np.array([[1000.0, 900.0], [200.0, 150.0], [600.0, 900.0]])
    out = two_opt_order(problem, pts)
    assert sorted(map(tuple, out)) == sorted(map(tuple, pts))  # a permutation

    def flight(p: np.ndarray) -> float:
        n = np.vstack([problem.start, p, problem.end])
        return float(problem.model.flight_time(np.linalg.norm(np.diff(n, axis=0), axis=1)).sum())

    assert flight(out) < flight(pts)


def test_refine_candidates_are_valid_and_the_lp_one_not_worse(problem: Problem) -> None:
    st = init(problem, 0, 12, 100)
    x = to_problem(problem, st.X[st.best])
    cand = refine(problem, x)
    assert cand.ndim == 2 and cand.shape[1] == problem.dim and len(cand) >= 1
    assert np.all(cand >= problem.lower - 1e-9) and np.all(cand <= problem.upper + 1e-9)
    f, phi = problem.evaluate(cand)
    f0, phi0 = problem.evaluate(x[None, :])
    # the first candidate is the elite re-ordered with LP times: feasible stays feasible, and
    # on this small map it is no slower
    if phi0[0] == 0.0:
        assert phi[0] == 0.0 and f[0] <= f0[0] + 1e-6
    np.testing.assert_array_equal(refine(problem, x), cand)  # deterministic


def test_memetic_step_counts_its_evaluations_and_keeps_the_elite(problem: Problem) -> None:
    b = BudgetedProblem(problem, 200)
    st = init(b, 1, 12, 200)
    nxt = memetic_step(st, b, partial(refine, problem))
    assert (
        nxt.evaluations == b.count == 12 + len(refine(problem, to_problem(problem, st.X[st.best])))
    )
    assert (nxt.best_phi, nxt.best_f) <= (st.best_phi, st.best_f)


def test_run_with_memetic_spends_exactly_the_budget(problem: Problem) -> None:
    b = BudgetedProblem(problem, 517)
    res = run(b, seed=3, population=12, budget=517, refine=partial(refine, problem))
    assert res.evaluations == b.count == 517
    again = run(
        BudgetedProblem(problem, 517),
        seed=3,
        population=12,
        budget=517,
        refine=partial(refine, problem),
    )
    np.testing.assert_array_equal(res.x, again.x)


def test_polish_elite_includes_the_best_and_never_loses_to_it(problem: Problem) -> None:
    from planner_core.polish import polish_elite, polish_hover_times

    res = run(BudgetedProblem(problem, 300), seed=2, population=12, budget=300)
    st = res.state
    X = to_problem(problem, st.X)
    xs, pols = polish_elite(problem, X, st.f, st.phi, 5)
    assert 1 <= len(xs) == len(pols) <= 5
    b = problem.breakdown(res.x)
    one = polish_hover_times(problem, b["hover_points"], b["hover_times"])
    only = problem.encode(one.hover_points, one.hover_times)
    np.testing.assert_array_equal(xs[0], only)  # the first is the DE's Deb-best, polished
    f, phi = problem.evaluate(xs)
    f1, phi1 = problem.evaluate(only[None, :])
    assert (phi.min(), f[phi == phi.min()].min()) <= (phi1[0], f1[0])
