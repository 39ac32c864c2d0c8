"""Random search: uniform samples in the box, best under Deb's rule (the floor of the table)."""

from __future__ import annotations

from typing import Any

import numpy as np

from planner_core.bench.baselines import OptimiseResult
from planner_core.pipeline.evaluator import as_evaluator

__all__ = ["optimise", "BATCH"]

#: samples evaluated per call (small enough for a fine convergence trace)
BATCH = 100


def optimise(problem: Any, budget: int, seed: int) -> OptimiseResult:
    """Evaluate `budget` uniform samples in the box in batches of `BATCH`; return the Deb-best.

    Args:
        problem: the problem (`lower`, `upper`, `evaluate`), or a fresh `Evaluator`.
        budget: evaluations, all spent.
        seed: the run's seed.

    Returns:
        The `OptimiseResult` of the Deb-best sample.
    """
    budgeted = as_evaluator(problem, budget)
    rng = np.random.default_rng(np.random.SeedSequence(int(seed)))
    lo, hi = budgeted.lower, budgeted.upper
    while budgeted.remaining > 0:
        n = min(BATCH, budgeted.remaining)
        budgeted.evaluate(lo + rng.random((n, lo.shape[0])) * (hi - lo))
    x, f, phi = budgeted.best("deb")
    return OptimiseResult(x, f, phi, budgeted.count, budgeted.trace("deb"))
