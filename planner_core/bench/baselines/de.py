"""Our DE (planner_core.search.de) as a benchmark entry: fixed, random or adaptive configurator.

Reports the raw DE result (Deb-best of the final population, no hover polish), so the benchmark
compares optimisers alone. The encoding (variable- or fixed-length) is the given problem's.
"""

from __future__ import annotations

from typing import Any

from planner_core.bench.baselines import OptimiseResult
from planner_core.bench.baselines.budget import as_budgeted
from planner_core.defaults import CONFIGURATOR, MIN_POPULATION
from planner_core.defaults import POPULATION as _POPULATION
from planner_core.search.de import run

__all__ = ["optimise", "POPULATION"]

#: population size of our DE in the benchmark (the planner's default)
POPULATION = _POPULATION


def optimise(
    problem: Any,
    budget: int,
    seed: int,
    *,
    configurator: str = CONFIGURATOR,
    lp: bool = False,
    memetic: bool | str = False,
    policy: str | None = None,
    starts: int = 0,
    candidates: int = 0,
    order: Any = None,
    descents: int = 0,
    trials: int = 0,
    restructure: int = 0,
    kick: int = 0,
    other: int = 0,
) -> OptimiseResult:
    """Run the DE with `configurator` for exactly `budget` evaluations (initial population
    included). `lp`: what `plan` does, the DE on budget - ELITE, then the hover-time LP on the
    final population's ELITE Deb-best (`planner_core.search.polish.polish_elite`, the last ELITE
    evaluations). `memetic`: with the
    memetic step on the elite (`planner_core.search.refine.refine`, when the problem can decode);
    a str is the defaults table's setting ("auto": on from a uniform start, as `plan` does).
    `policy`: a policy checkpoint folder (or shipped name) for `configurator="lamde"` (the
    ablation variants); None = the shipped default. `starts`, `candidates`: as `plan` does, the
    `starts` Deb-best of up to `candidates` constructive plans (`planner_core.search.construct`,
    visiting order `order`, default its own open path; one evaluation each, counted) put into
    the DE's initial population (UAV problem only; 0: none). `descents`, `trials`: as `plan`
    does, the hover-point descent (`planner_core.search.descent`) on the `descents` best plans of
    each kind among the starts and, with `lp`, on the polished best, at most `trials`
    evaluations each, then `restructure` evaluations of the structural search and `kick` of
    the iterated local search on it, and at most `other` evaluations of the same on the best
    start with fewer (else more) hover points (the polished best gets them when there is
    none; `planner_core.search.final.finish`; UAV problem only; 0: none)."""
    from planner_core.bench.baselines.seed_lp import can_lp

    budgeted = as_budgeted(problem, budget)
    from planner_core.search.final import final_budget
    from planner_core.search.polish import ELITE

    reserve = min(ELITE, int(budget) // 4) if lp and can_lp(budgeted) else 0
    population = min(POPULATION, int(budget))
    if population < MIN_POPULATION:
        raise ValueError(f"budget {budget} is below the DE's minimum population {MIN_POPULATION}")
    if policy is not None:
        if configurator != "lamde":
            raise ValueError(f"policy: only with configurator 'lamde', not {configurator!r}")
        from planner_core.learning.policy import PolicyConfigurator

        configurator = PolicyConfigurator(checkpoint=policy)  # type: ignore[assignment]
    refine = None
    if isinstance(memetic, str):
        from planner_core.search.refine import use_memetic

        memetic = use_memetic(memetic, budgeted)
    if memetic and can_lp(budgeted):
        from functools import partial

        from planner_core.search.refine import refine as _refine

        refine = partial(_refine, budgeted.problem)
    opt, spent = budgeted, 0
    room = max(int(budget) - reserve - population, 0)
    own = int(trials) + int(restructure) + int(kick)
    final = final_budget(room, own + int(other)) if own and descents > 0 and reserve else 0
    room -= final
    if starts > 0 and candidates > 0 and can_lp(budgeted):
        from planner_core.search.construct import start_from_plans

        opt, spent = start_from_plans(budgeted.problem, budgeted, int(seed), starts=int(starts),
                                      candidates=min(int(candidates), room), order=order,
                                      descents=int(descents), trials=int(trials), room=room)
    res = run(opt, configurator=configurator, seed=int(seed), population=population,
              budget=int(budget) - reserve - final - spent, refine=refine)
    last_feasible = float(res.history.feasible_fraction[-1])  # the DE's last population
    if reserve:
        from planner_core.search.de.core import to_problem
        from planner_core.search.polish import polish_elite

        st = res.state
        inner = budgeted.problem
        xs, _ = polish_elite(inner, to_problem(budgeted, st.X), st.f, st.phi, reserve)
        budgeted.evaluate(xs)
        x, f, phi = budgeted.best("deb")
        if final and phi == 0.0:
            from planner_core.search.final import final_stage

            # budgeted keeps the best
            final_stage(inner, x, budgeted.evaluate, final=final, own=own,
                        starts=getattr(opt, "starts", None), seed=int(seed),
                        descent_trials=int(trials), restructure_trials=int(restructure))
            x, f, phi = budgeted.best("deb")
        return OptimiseResult(x, f, phi, budgeted.count, budgeted.trace("deb"), last_feasible)
    return OptimiseResult(res.x, res.f, res.phi, budgeted.count, budgeted.trace("deb"),
                          last_feasible)
