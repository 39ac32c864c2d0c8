"""The planner started from the engineering pipeline's plans: an experiment for issue 14's
"diverse constructive starts" (benchmark entry `planner-eng-start`; the product is unchanged).

1. The plain engineering pipeline (`planner_core.baselines.engineering`) builds and scores its
   candidate plans (greedy set covers, k-means sweep, OR-Tools order, visibility-graph detours,
   LP hover times; one evaluation each, typically 20-44).
2. The planner (`planner_core.baselines.de`, exactly the `planner` entry: our DE with the
   adaptive configurator, population 100, memetic step "auto", the polish LP on the final
   population's 16 Deb-best) runs on the rest of the budget, its initial population the one its
   start mode gives (the seeded hook, or uniform) with the last `STARTS` rows replaced by the
   engineering pipeline's `STARTS` Deb-best distinct plans (the seeded hook's sensor-aware half
   is kept; those rows are evaluated again by the DE and counted).

The answer is the Deb-best of everything evaluated, so it is never worse than `engineering` for
the same seed; the budget is spent exactly.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from planner_core.baselines import OptimiseResult
from planner_core.baselines.budget import as_budgeted
from planner_core.defaults import MEMETIC
from planner_core.model import deb_order

__all__ = ["STARTS", "optimise"]

#: engineering plans put into the DE's initial population
STARTS = 10


class _WithStarts:
    """A problem whose `initial_population(rng, n)` is its own (or uniform, when it has none)
    with the last rows replaced by `starts` (k, d); everything else is the problem's."""

    def __init__(self, problem: Any, starts: np.ndarray) -> None:
        self.problem = problem
        self.starts = np.asarray(starts, dtype=float)

    def __getattr__(self, name: str) -> Any:
        if name in ("problem", "starts"):
            raise AttributeError(name)
        return getattr(self.problem, name)

    def initial_population(self, rng: np.random.Generator, n: int) -> np.ndarray:
        hook = getattr(self.problem, "initial_population", None)
        if hook is not None:
            X = np.array(hook(rng, n), dtype=float)
        else:  # the uniform start mode: what the DE itself would draw
            lo, hi = np.asarray(self.lower), np.asarray(self.upper)
            X = lo + rng.random((n, lo.shape[0])) * (hi - lo)
        k = min(len(self.starts), n)
        if k:
            X[n - k :] = self.starts[:k]
        return X


def optimise(problem: Any, budget: int, seed: int, *, starts: int = STARTS) -> OptimiseResult:
    """The engineering pipeline's candidates, then the planner from a population holding its
    `starts` best (module docstring); exactly `budget` evaluations."""
    from planner_core.baselines.de import optimise as planner
    from planner_core.baselines.engineering import score_candidates
    from planner_core.memetic import use_memetic

    budgeted = as_budgeted(problem, budget)
    X, f, phi = score_candidates(budgeted, seed)
    best = X[deb_order(f, phi)[:starts]] if len(X) else X
    if budgeted.remaining > 0:
        # memetic "auto" as for `planner`: judged on the start mode, before the starts go in
        memetic = use_memetic(MEMETIC, budgeted)
        seeded = _WithStarts(budgeted, best)  # its seeder is the problem's (attributes pass)
        planner(seeded, budgeted.remaining, seed, lp=True, memetic=memetic)
    x, fb, pb = budgeted.best("deb")
    return OptimiseResult(x, fb, pb, budgeted.count, budgeted.trace("deb"))
