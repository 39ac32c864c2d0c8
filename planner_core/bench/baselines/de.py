"""Our optimisers as benchmark entries: the DE alone (`optimise`) and the planner (`planner`).

`optimise` reports the raw DE result (Deb-best of everything it evaluated, no hover polish), so
the benchmark compares optimisers alone; the encoding (variable- or fixed-length) is the given
problem's. `planner` is what `plan` does: the declared pipeline
(`planner_core.pipeline.run_pipeline`) through the benchmark's own counted evaluator, with
`PlanConfig` settings as the entry's keyword arguments.
"""

from __future__ import annotations

from typing import Any

from planner_core.bench.baselines import OptimiseResult
from planner_core.defaults import CONFIGURATOR, MIN_POPULATION
from planner_core.defaults import POPULATION as _POPULATION
from planner_core.pipeline.evaluator import as_evaluator

__all__ = ["optimise", "planner", "POPULATION"]

#: population size of our DE in the benchmark (the planner's default)
POPULATION = _POPULATION


def _configurator(configurator: Any, policy: str | None) -> Any:
    if policy is None:
        return configurator
    if configurator != "lamde":
        raise ValueError(f"policy: only with configurator 'lamde', not {configurator!r}")
    from planner_core.learning.policy import PolicyConfigurator

    return PolicyConfigurator(checkpoint=policy)


def optimise(
    problem: Any,
    budget: int,
    seed: int,
    *,
    configurator: str | Any = CONFIGURATOR,
    policy: str | None = None,
) -> OptimiseResult:
    """Run the DE alone with `configurator` for exactly `budget` evaluations (initial
    population included), population `POPULATION` (the budget when smaller).

    Args:
        problem: a problem or a fresh `Evaluator` with this budget.
        budget: evaluations, >= `MIN_POPULATION`.
        seed: the run's seed.
        configurator: a registry name or a configurator object.
        policy: a policy checkpoint folder (or shipped name) for `configurator="lamde"` (the
            ablation variants); None: the shipped default.

    Returns:
        The Deb-best solution evaluated, its count and trace.

    Raises:
        ValueError: a budget below `MIN_POPULATION`, or `policy` without "lamde".
    """
    from planner_core.search.de import run

    ev = as_evaluator(problem, budget)
    population = min(POPULATION, int(budget))
    if population < MIN_POPULATION:
        raise ValueError(f"budget {budget} is below the DE's minimum population {MIN_POPULATION}")
    res = run(ev, configurator=_configurator(configurator, policy), seed=int(seed),
              population=population, budget=int(budget))
    x, f, phi = ev.best("deb")
    return OptimiseResult(x, f, phi, ev.count, ev.trace("deb"),
                          float(res.history.feasible_fraction[-1]))


def planner(
    problem: Any, budget: int, seed: int, *, policy: str | None = None,
    scheduler: str | None = None, **settings: Any
) -> OptimiseResult:
    """What `plan` does, on the benchmark's problem and counter: the default pipeline with
    `PlanConfig(budget=budget, seed=seed, **settings)` (`policy` as `optimise`; the start mode
    is the problem's, as the benchmark wrapped it, so `init` is not a setting here).

    Args:
        problem: the UAV problem in the run's start mode, or a fresh `Evaluator` over it.
        budget: evaluations in all (>= the population).
        seed: the run's seed.
        policy: see `optimise`.
        scheduler: the improving stage's scheduler (`plan --scheduler`; None: the default),
            e.g. "lamde-s", which also sets the DE's share from the map.
        settings: any other `PlanConfig` field (configurator, starts, descent, memetic, ...).

    Returns:
        The pipeline's answer (the Deb-best of everything evaluated), its count and trace.

    Raises:
        ValueError: a setting outside its range (one line naming it).
    """
    from planner_core.pipeline import PlanConfig, run_pipeline

    ev = as_evaluator(problem, budget)
    inner = ev.problem
    uav = getattr(inner, "problem", inner)  # under the uniform start's wrapper
    if "configurator" in settings or policy is not None:
        settings["configurator"] = _configurator(settings.get("configurator", "lamde"), policy)
    settings.setdefault("population", min(POPULATION, int(budget)))
    config = PlanConfig(budget=int(budget), seed=int(seed), **settings)
    r = run_pipeline(uav, config, evaluator=ev, scheduler=scheduler)
    de = r.state.de
    last = None if de is None else float(de.history.feasible_fraction[-1])
    return OptimiseResult(r.x, r.f, r.phi, ev.count, ev.trace("deb"), last)
