"""Our DE (planner_core.de) as a benchmark entry: fixed, random or adaptive configurator.

Reports the raw DE result (Deb-best of the final population, no hover polish), so the benchmark
compares optimisers alone. The encoding (variable- or fixed-length) is the given problem's.
"""

from __future__ import annotations

from typing import Any

from planner_core.baselines import OptimiseResult
from planner_core.baselines.budget import as_budgeted
from planner_core.de import run
from planner_core.defaults import CONFIGURATOR, MIN_POPULATION
from planner_core.defaults import POPULATION as _POPULATION

__all__ = ["optimise", "POPULATION"]

#: population size of our DE in the benchmark (the planner's default)
POPULATION = _POPULATION


def optimise(
    problem: Any, budget: int, seed: int, *, configurator: str = CONFIGURATOR
) -> OptimiseResult:
    """Run the DE with `configurator` for exactly `budget` evaluations (initial population
    included)."""

    budgeted = as_budgeted(problem, budget)
    population = min(POPULATION, int(budget))
    if population < MIN_POPULATION:
        raise ValueError(f"budget {budget} is below the DE's minimum population {MIN_POPULATION}")
    res = run(budgeted, configurator=configurator, seed=int(seed), population=population,
              budget=int(budget))
    return OptimiseResult(res.x, res.f, res.phi, budgeted.count, budgeted.trace("deb"),
                          float(res.history.feasible_fraction[-1]))
