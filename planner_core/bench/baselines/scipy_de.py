"""`scipy.optimize.differential_evolution` on the penalised score f + 10 * phi, budget-capped.

Scipy's defaults (best1bin, dithered F in (0.5, 1), CR 0.7, tol 0.01) except: the population is 100
Latin-hypercube points like our DE (scipy's default 15 * dim = 600..1200 individuals would leave
only 7..15 generations in 10,000 evaluations), `updating='deferred'` with `vectorized=True` (whole
generations evaluated as one batch), and no gradient polish (it would spend evaluations outside the
budget). The objective wrapper counts evaluations and stops at the budget exactly (the first
population comes from the problem's `initial_population` hook when it has one, as for our DE): in
the last generation only the first candidates that fit are evaluated (the rest get +inf, so they
never enter the population) and the callback ends the run. If scipy converges before the budget is
spent, it restarts with a fresh population and the budget left. Returns the best penalised score
seen.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from scipy.optimize import differential_evolution
from scipy.stats import qmc

from planner_core.bench.baselines import OptimiseResult
from planner_core.defaults import POPULATION as _POPULATION
from planner_core.model.formulas import penalised_score
from planner_core.pipeline.evaluator import as_evaluator

__all__ = ["optimise", "POPULATION"]

#: population size (scipy's `init` array); at least 5 as scipy requires
POPULATION = _POPULATION


def optimise(
    problem: Any, budget: int, seed: int, *, population: int = POPULATION
) -> OptimiseResult:
    """Scipy's DE with restarts until exactly `budget` evaluations; best under f + 10 * phi.

    Args:
        problem: the problem (`lower`, `upper`, `evaluate`; optionally the
            `initial_population` hook, used for the first population), or a fresh `Evaluator`.
        budget: evaluations, all spent (the last fewer than 5 as uniform samples).
        seed: the run's seed.
        population: population size (at least 5, as scipy requires).

    Returns:
        The `OptimiseResult` of the best penalised score seen.
    """

    budgeted = as_evaluator(problem, budget)
    lo, hi = budgeted.lower, budgeted.upper
    span = hi - lo
    d = lo.shape[0]

    def objective(Ut: np.ndarray) -> np.ndarray:
        U = np.atleast_2d(np.asarray(Ut, dtype=float).T)  # scipy passes (d, S)
        out = np.full(U.shape[0], np.inf)
        k = min(U.shape[0], budgeted.remaining)
        if k > 0:
            f, phi = budgeted.evaluate(lo + np.clip(U[:k], 0.0, 1.0) * span)
            out[:k] = penalised_score(f, phi)
        return out

    def stop(intermediate_result: Any) -> bool:  # scipy picks the signature by name
        return budgeted.exhausted

    restart = 0
    while budgeted.remaining >= 5:
        n = max(5, min(int(population), budgeted.remaining))
        rng = np.random.default_rng(np.random.SeedSequence([int(seed), restart]))
        init = qmc.LatinHypercube(d=d, rng=rng).random(n)
        sampler = getattr(problem, "initial_population", None)
        if sampler is not None and restart == 0:
            # the same problem-provided starts our DE gets (e.g. sensor-aware hover points)
            init = np.clip((np.asarray(sampler(rng, n), dtype=float) - lo) / span, 0.0, 1.0)
        differential_evolution(
            objective,
            [(0.0, 1.0)] * d,
            maxiter=math.ceil(budgeted.remaining / n) + 1,
            init=init,
            rng=rng,
            callback=stop,
            polish=False,
            updating="deferred",
            vectorized=True,
        )
        restart += 1
    if budgeted.remaining > 0:  # fewer than 5 left: too few for a population, sample them
        rng = np.random.default_rng(np.random.SeedSequence([int(seed), restart]))
        budgeted.evaluate(lo + rng.random((budgeted.remaining, d)) * span)
    x, f, phi = budgeted.best("penalised")
    return OptimiseResult(x, f, phi, budgeted.count, budgeted.trace("penalised"))
