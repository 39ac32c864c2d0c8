""" "Best seed + LP, no search": the floor every search must beat (issue 14).

Builds exactly our DE's initial population for this seed (`planner_core.search.de.core.init`: the
seeder's obstacle-aware sensor routes plus uniform points, POPULATION evaluations), takes its
Deb-best point, re-solves its hover times with the hover-time LP of `planner_core.search.polish`
(the
polish `plan` applies to the DE's answer) and evaluates that once more. The result is the Deb-best
of everything evaluated, so POPULATION + 1 evaluations of the budget are used; the rest is left
unspent on purpose (the point of the entry is that it does no search).

`lp_finish` is the same LP step for any optimiser's answer, so peers can be compared like for
like (all followed by the same LP).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from planner_core.bench.baselines import OptimiseResult
from planner_core.defaults import MIN_POPULATION, POPULATION
from planner_core.pipeline.evaluator import Evaluator, as_evaluator

__all__ = ["optimise", "lp_finish", "can_lp"]


def can_lp(budgeted: Evaluator) -> bool:
    """True when the wrapped problem can decode and encode plans (the LP step applies).

    Args:
        budgeted: the run's `Evaluator`.

    Returns:
        Whether its problem has `encode` and `breakdown`.
    """
    inner = budgeted.problem
    return hasattr(inner, "encode") and hasattr(inner, "breakdown")


def lp_finish(budgeted: Evaluator, x: np.ndarray) -> None:
    """Re-solve the hover times of `x` by the polish LP (`planner_core.search.polish`) and
    evaluate the result (one evaluation, when the budget has one left and the problem can
    encode plans); the budgeted problem's best then includes it. Problems without
    `breakdown`/`encode` are left alone.

    Args:
        budgeted: the run's `Evaluator`.
        x: (d,) decision vector in problem space.
    """
    inner = budgeted.problem
    if budgeted.remaining < 1 or not can_lp(budgeted):
        return
    from planner_core.search.polish import polish_hover_times

    b = inner.breakdown(np.asarray(x, dtype=float))
    pol = polish_hover_times(inner, b["hover_points"])
    budgeted.evaluate(inner.encode(pol.hover_points, pol.hover_times)[None, :])


def optimise(problem: Any, budget: int, seed: int) -> OptimiseResult:
    """The DE's seeded initial population for `seed`, its Deb-best, the LP on it; no search.

    Args:
        problem: the UAV problem, or a fresh `Evaluator` of it.
        budget: evaluations at most; POPULATION + 1 of them are used (fewer when the budget
            is smaller).
        seed: the run's seed.

    Returns:
        The `OptimiseResult` of the Deb-best of everything evaluated.

    Raises:
        ValueError: a budget below the minimum population + 1.
    """
    from planner_core.search.de.core import init, to_problem

    budgeted = as_evaluator(problem, budget)
    population = min(POPULATION, int(budget) - 1)
    if population < MIN_POPULATION:
        raise ValueError(f"budget {budget} is below the seeded population + 1")
    state = init(budgeted, int(seed), population, int(budget))
    lp_finish(budgeted, to_problem(budgeted, state.X[state.best]))
    x, f, phi = budgeted.best("deb")
    return OptimiseResult(x, f, phi, budgeted.count, budgeted.trace("deb"))
