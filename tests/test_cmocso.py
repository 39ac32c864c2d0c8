"""CMOCSO (planner_core/bench/baselines/cmocso.py): its fitness and selection, budget, seed, and
that it optimises (a constrained toy with a known answer, a suite map against random search)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from planner_core.bench.baselines import Evaluator, cmocso, optimise
from planner_core.model.formulas import PENALTY_FACTOR
from planner_core.model.problem import Problem

SUITE = Path(__file__).resolve().parents[1] / "examples" / "maps" / "suite"


class Toy:
    """min |x - (0.2, 0.2)|^2 subject to x0 >= 0.5 in [-1, 2]^2: x* = (0.5, 0.2), f* = 0.09."""

    lower = np.array([-1.0, -1.0])
    upper = np.array([2.0, 2.0])

    def evaluate(self, X: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        X = np.atleast_2d(X)
        return ((X - 0.2) ** 2).sum(axis=1), np.maximum(0.0, 0.5 - X[:, 0])


def test_fitness_is_the_epsilon_constrained_order_for_one_objective() -> None:
    f = np.array([3.0, 1.0, 2.0, 0.5])
    cv = np.array([0.0, 0.0, 0.2, 5.0])
    # constraints ignored: order by f
    assert list(np.argsort(cmocso.fitness(f, cv, np.inf))) == [3, 1, 2, 0]
    # epsilon 0: violation first, then f
    assert list(np.argsort(cmocso.fitness(f, cv, 0.0))) == [1, 0, 2, 3]
    # epsilon 1: the 0.2 violation counts as feasible, the 5.0 does not
    assert list(np.argsort(cmocso.fitness(f, cv, 1.0))) == [1, 2, 0, 3]
    # only the best is non-dominated (fitness < 1)
    assert np.count_nonzero(cmocso.fitness(f, cv, 0.0) < 1.0) == 1


def test_fitness_two_objectives_and_truncation() -> None:
    # a front of four points and one dominated point (SPEA2 with M = 2)
    obj = np.array([[0.0, 1.0], [0.1, 0.9], [0.5, 0.5], [1.0, 0.0], [1.0, 1.0]])
    cv = np.zeros(5)
    fit = cmocso.fitness(obj, cv, 0.0)
    assert np.all(fit[:4] < 1.0) and fit[4] >= 1.0
    # keep 3 of the 4 non-dominated: one of the crowded pair (0, 1) goes
    kept = cmocso.select(obj, cv, 3, 0.0)
    assert len(kept) == 3 and {2, 3} <= set(kept.tolist()) and 4 not in kept


def test_same_seed_same_bytes_and_seed_matters() -> None:
    a = cmocso.optimise(Toy(), 1000, 3)
    b = cmocso.optimise(Toy(), 1000, 3)
    c = cmocso.optimise(Toy(), 1000, 4)
    assert a.x.tobytes() == b.x.tobytes() and a.f == b.f
    assert a.history.best_f.tobytes() == b.history.best_f.tobytes()
    assert a.x.tobytes() != c.x.tobytes()


@pytest.mark.parametrize("budget", [100, 317, 1001])
def test_budget_spent_exactly(budget: int) -> None:
    counted: list[int] = []

    class Spy(Toy):
        def evaluate(self, X: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
            counted.append(len(X))
            return super().evaluate(X)

    ev = Evaluator(Spy(), budget)  # raises BudgetExceeded if CMOCSO asked for more
    res = cmocso.optimise(ev, budget, 0)
    assert sum(counted) == budget == res.evaluations == ev.count


def test_bad_population_or_budget() -> None:
    with pytest.raises(ValueError, match="population"):
        cmocso.optimise(Toy(), 1000, 0, population=7)
    with pytest.raises(ValueError, match="budget"):
        cmocso.optimise(Toy(), 50, 0)


def test_solves_the_constrained_toy() -> None:
    for seed in range(3):
        res = cmocso.optimise(Toy(), 2000, seed)
        assert res.phi == 0.0
        assert res.f < 0.09 + 0.01, (seed, res.f, res.x)
        assert abs(res.x[0] - 0.5) < 0.02


@pytest.mark.slow  # measured 6.3 s (two maps' worth of runs at 2,000 evaluations, shared CPU)
def test_beats_random_search_on_a_suite_map() -> None:
    # T14 (25 sensors): random search rarely gets near the sensors; the swarms do. On the
    # 3-sensor map of test_baselines.py random search is better at 2,000 evaluations (60 vs 64).
    problem = Problem(json.loads((SUITE / "T14.json").read_text()))
    for seed in range(2):
        a = optimise("cmocso", problem, 2000, seed, init="uniform")
        b = optimise("random-search", problem, 2000, seed, init="uniform")
        assert a.f + PENALTY_FACTOR * a.phi < b.f + PENALTY_FACTOR * b.phi
