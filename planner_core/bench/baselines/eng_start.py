"""The planner started from the `engineering` entry's plans (benchmark entry
`planner-eng-start`): issue 14's experiment that led to `plan`'s constructive starts, kept to
compare with them.

Exactly the `planner` entry (`planner_core.bench.baselines.de`, `plan`'s pipeline) with two
differences in the constructive starts (`planner_core.search.construct`): every candidate plan the
pipeline builds is scored (typically 20-51; `planner` scores the first `START_CANDIDATES`), and
the site sets are ordered by OR-Tools' routing solver (the `engineering` entry's order) instead
of the planner's own open path. The `STARTS` Deb-best go into the DE's initial population in
place of its last rows; the answer is the Deb-best of everything evaluated, so it is never worse
than `engineering` for the same seed; at most the budget is spent (the improving rounds may
stop early). Needs the `baselines` extra.
"""

from __future__ import annotations

from typing import Any

from planner_core.bench.baselines import OptimiseResult

__all__ = ["STARTS", "optimise"]

#: engineering plans put into the DE's initial population
STARTS = 10


def optimise(problem: Any, budget: int, seed: int, *, starts: int = STARTS) -> OptimiseResult:
    """The engineering pipeline's candidates (all, OR-Tools order), then the planner from a
    population holding its `starts` best (module docstring); at most `budget` evaluations.

    Args:
        problem: the UAV problem (or an `Evaluator` of it).
        budget: evaluations at most (also the number of candidates that may be scored).
        seed: the run's seed.
        starts: engineering plans put into the DE's initial population.

    Returns:
        The `OptimiseResult` of `planner_core.bench.baselines.de.planner`.
    """
    from planner_core.bench.baselines.de import planner
    from planner_core.bench.baselines.engineering import ortools_order

    return planner(problem, budget, seed, starts=starts, start_candidates=int(budget),
                   order=ortools_order)
