"""pymoo's genetic algorithm with its native constraint handling, then the hover-time LP
(issue 14's constrained-GA peer).

Algorithm: `pymoo.algorithms.soo.nonconvex.ga.GA` (Blank & Deb 2020, "pymoo: Multi-Objective
Optimization in Python", IEEE Access 8) with pymoo's defaults for continuous variables: binary
tournament selection comparing by constraint violation first, then f (`comp_by_cv_and_fitness`,
Deb's feasibility rules, Deb 2000), SBX crossover, polynomial mutation, duplicate elimination,
and `FitnessSurvival` (sorted by violation, then f: feasibility first). Population `POPULATION`
(100), offspring 100 per generation. The problem is given to pymoo as one objective f and one
inequality constraint G = phi <= 0 (phi = V3 + V4 + V5 >= 0, so pymoo's violation is phi itself),
in the problem's own box.

Budget (ask/tell, every evaluation through the shared `Evaluator`): the first generation is
exactly our DE's initial population for this seed (`planner_core.search.de.core.init`: the problem's
`initial_population` hook in the seeded start mode, uniform in the unit box in the uniform mode;
POPULATION evaluations, as for `planner` and `cmaes-seeded-lp`, so runs of one seed are paired);
each later generation evaluates pymoo's offspring; when fewer evaluations remain than offspring,
only the first ones are evaluated and that partial generation is never told (as `cmaes`). Should
pymoo's mating produce no new offspring (all duplicates), a fresh GA restarts from the best point
so far plus uniform points (and when even that finds nothing new, as in a box of zero width,
the run stops with budget left). One evaluation is kept for the same hover-time LP every peer
ends with (`planner_core.bench.baselines.seed_lp.lp_finish`) on the Deb-best point; the count is
exact.
Deterministic for a seed (pymoo 0.6.2 draws from its own `numpy.random.Generator`).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from planner_core.bench.baselines import OptimiseResult
from planner_core.defaults import MIN_POPULATION, POPULATION
from planner_core.pipeline.evaluator import as_evaluator

__all__ = ["optimise"]


def _ga_seed(seed: int, restart: int) -> int:
    """A 31-bit seed for pymoo per (run seed, restart)."""
    return int(np.random.SeedSequence([int(seed), 2**21, restart]).generate_state(1)[0] >> 1)


def optimise(
    problem: Any, budget: int, seed: int, *, population: int = POPULATION
) -> OptimiseResult:
    """pymoo GA (feasibility first) on f with G = phi <= 0 until the budget less one is spent,
    then the LP on the Deb-best point (module docstring).

    Args:
        problem: the problem (`lower`, `upper`, `evaluate`; the LP needs `encode` and
            `breakdown`), or a fresh `Evaluator` with this budget.
        budget: evaluations at most.
        seed: the run's seed (the start population's and pymoo's).
        population: GA population (capped at the budget less the LP's evaluation).

    Returns:
        The `OptimiseResult` of the Deb-best seen.

    Raises:
        ValueError: a budget below the minimum population + the LP's evaluation.
    """
    from pymoo.algorithms.soo.nonconvex.ga import GA
    from pymoo.core.evaluator import Evaluator
    from pymoo.core.problem import Problem as PymooProblem
    from pymoo.core.termination import NoTermination
    from pymoo.problems.static import StaticProblem

    from planner_core.bench.baselines.seed_lp import can_lp, lp_finish
    from planner_core.search.de.core import init, to_problem

    budgeted = as_evaluator(problem, budget)
    reserve = 1 if can_lp(budgeted) else 0
    population = min(int(population), int(budget) - reserve)
    if population < MIN_POPULATION:
        raise ValueError(f"budget {budget} is below the population + {reserve}")
    lo, hi = budgeted.lower, budgeted.upper
    box = PymooProblem(n_var=len(lo), n_obj=1, n_ieq_constr=1, xl=lo, xu=hi)
    # generation 0: the DE's own start for this seed (seeded or uniform, as the problem shows)
    state = init(budgeted, int(seed), population, int(budget))
    X0 = np.asarray(to_problem(budgeted, state.X), dtype=float)
    known = {X0[i].tobytes(): (float(state.f[i]), float(state.phi[i])) for i in range(len(X0))}
    sampling: np.ndarray = X0
    restart = 0
    while budgeted.remaining > reserve:
        before = budgeted.count
        ga = GA(pop_size=population, sampling=sampling, eliminate_duplicates=True)
        ga.setup(box, termination=NoTermination(), seed=_ga_seed(seed, restart), verbose=False)
        while budgeted.remaining > reserve:
            pop = ga.ask()
            if pop is None or len(pop) == 0:
                break  # mating found no new offspring: restart
            X = np.asarray(pop.get("X"), dtype=float)
            f = np.empty(len(X))
            phi = np.empty(len(X))
            seen = [known.get(row.tobytes()) for row in X]  # already evaluated (generation 0)
            todo = [i for i, v in enumerate(seen) if v is None]
            for i, v in enumerate(seen):
                if v is not None:
                    f[i], phi[i] = v
            k = min(len(todo), budgeted.remaining - reserve)
            if k:
                fe, pe = budgeted.evaluate(X[todo[:k]])
                f[todo[:k]], phi[todo[:k]] = fe, pe
            if k < len(todo):
                break  # budget spent mid-generation: never tell a partial generation
            known.clear()
            # pymoo's own bookkeeping of F, G and the violation CV from our values
            static = StaticProblem(box, F=f[:, None], G=phi[:, None])
            Evaluator().eval(static, pop)
            ga.tell(infills=pop)
        if restart > 0 and budgeted.count == before:
            break  # a restart that finds nothing new to evaluate (a degenerate box): stop
        restart += 1
        best, bf, bp = budgeted.best("deb")
        known = {best.tobytes(): (bf, bp)}  # the restart keeps it without a new evaluation
        rng = np.random.default_rng(_ga_seed(seed, restart))
        uniform = lo + rng.random((population - 1, len(lo))) * (hi - lo)
        sampling = np.vstack([best[None, :], uniform])
    if reserve:
        lp_finish(budgeted, budgeted.best("deb")[0])
    x, f_best, phi_best = budgeted.best("deb")
    return OptimiseResult(x, f_best, phi_best, budgeted.count, budgeted.trace("deb"))
