"""The run loop: resolve a configurator name, then init and step until the budget is spent.

The only module of the DE that knows the configurator registry; the core (init / ask / tell /
step) takes configurator objects.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable

import numpy as np

from planner_core.defaults import BUDGET, CONFIGURATOR, POPULATION
from planner_core.search.de.configurators import make_configurator
from planner_core.search.de.core import init, step, to_problem
from planner_core.search.de.refine_step import due, memetic_step
from planner_core.search.de.rng import Streams
from planner_core.search.de.types import (
    BoxProblem,
    Configurator,
    DEState,
    History,
    Progress,
    Result,
)

__all__ = ["run"]


def _progress(state: DEState) -> Progress:
    return Progress(
        state.generation,
        state.evaluations,
        state.budget,
        state.best_f,
        state.best_phi,
        state.feasible_fraction,
    )


def run(
    problem: BoxProblem,
    *,
    configurator: Configurator | str = CONFIGURATOR,
    seed: int = 0,
    population: int = POPULATION,
    budget: int = BUDGET,
    callback: Callable[[Progress], None] | None = None,
    refine: Callable[[np.ndarray], np.ndarray] | None = None,
) -> Result:
    """Optimise ``problem`` until the budget is spent; same seed -> identical result.

    Args:
        problem: the problem (`lower`, `upper`, `evaluate`, optional `initial_population`).
        configurator: an object or a registry name ("fixed", "random", "adaptive", "lamde").
        seed: the run's seed, >= 0.
        population: N, >= `MIN_POPULATION`.
        budget: evaluations in all (the initial population's count), >= N.
        callback: receives a :class:`Progress` after the initial population and each
            generation (None: nothing).
        refine: a memetic step, x -> (m, d) candidates, run on the elite every
            `de.refine_step.PERIOD` generations (`planner_core.search.de.refine_step`; its
            evaluations count against the budget). None by default: measured, it does not
            change the polished result (docs/search.md).

    Returns:
        The `Result`: the Deb-best x (d,) in problem space, its f and phi, evaluations and
        generations spent, the per-generation `History`, the final `DEState`.

    Raises:
        ValueError: an unknown configurator name, or as `core.init` and `core.step`.
    """
    if isinstance(configurator, str):
        configurator = make_configurator(configurator)
    state = init(problem, seed, population, budget)
    state = dataclasses.replace(state, memory=configurator.init(state))
    trace = [_progress(state)]
    if callback is not None:
        callback(trace[-1])
    streams = Streams(state.seed)
    while not state.done:
        state, _ = step(state, problem, configurator, streams)
        if refine is not None and due(state):
            state = memetic_step(state, problem, refine)
        trace.append(_progress(state))
        if callback is not None:
            callback(trace[-1])
    history = History(
        evaluations=np.array([p.evaluations for p in trace], dtype=np.int64),
        best_f=np.array([p.best_f for p in trace]),
        best_phi=np.array([p.best_phi for p in trace]),
        feasible_fraction=np.array([p.feasible_fraction for p in trace]),
    )
    return Result(
        x=to_problem(problem, state.X[state.best]),
        f=state.best_f,
        phi=state.best_phi,
        evaluations=state.evaluations,
        generations=state.generation,
        history=history,
        state=state,
    )
