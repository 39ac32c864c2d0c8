"""The DE's memetic step: every `PERIOD` generations a refine function improves the elite.

Problem-agnostic: `de.loop.run(..., refine=...)` takes an optional function
``refine(x) -> (m, d)`` (problem-space candidates derived from the Deb-best solution x; for the
UAV problem, ``functools.partial(planner_core.search.refine.refine, problem)``: 2-opt order, exact
LP hover times, removals).
The candidates are evaluated like trials (they count against the budget; never more than it
has left). The Deb-best candidate, if Deb-better than the elite, replaces the Deb-worst
individual, so the elite survives too. The configurator protocol is untouched (per-individual
Config, memory): this step sits between generations, outside ask/tell.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from typing import Any

import numpy as np

from planner_core.model.formulas import deb_best, deb_better, deb_order
from planner_core.search.de.core import to_problem, to_unit
from planner_core.search.de.types import DEState

__all__ = ["PERIOD", "due", "memetic_step"]

#: generations between memetic steps (0 turns the step off)
PERIOD = 10


def due(state: DEState, period: int = PERIOD) -> bool:
    """Whether generation `state.generation` should refine.

    Args:
        state: the state after the generation.
        period: generations between memetic steps (<= 0: never).

    Returns:
        True when the period divides the generation (> 0) and budget is left.
    """
    return (
        period > 0
        and state.generation > 0
        and state.generation % period == 0
        and not state.done
    )


def _frozen(a: np.ndarray) -> np.ndarray:
    a = np.ascontiguousarray(a)
    a.setflags(write=False)
    return a


def memetic_step(
    state: DEState, problem: Any, refine: Callable[[np.ndarray], np.ndarray]
) -> DEState:
    """Refine the elite through `refine`, evaluate on `problem` (budget-counted), inject.

    Args:
        state: the DE's state.
        problem: the problem (bounds and `evaluate`).
        refine: x (d,) problem space -> candidates (m, d) problem space.

    Returns:
        The state with the first min(m, budget left) candidates' evaluations counted; the
        Deb-best of them, clamped to the box, in the Deb-worst individual's place (and the
        new best) when it is Deb-better than the elite; `state` itself when nothing could be
        evaluated.
    """
    x = to_problem(problem, state.X[state.best])
    cand = np.asarray(refine(x), dtype=float).reshape(-1, state.dim)
    k = min(len(cand), state.budget - state.evaluations)
    if k <= 0:
        return state
    U = to_unit(problem, cand[:k])
    f, phi = problem.evaluate(to_problem(problem, U))
    f = np.where(np.isnan(f), np.inf, np.asarray(f, dtype=float).reshape(-1))
    phi = np.where(np.isnan(phi), np.inf, np.asarray(phi, dtype=float).reshape(-1))
    state = dataclasses.replace(state, evaluations=state.evaluations + k)
    c = deb_best(f, phi)
    if not deb_better(f[c], phi[c], state.f[state.best], state.phi[state.best]):
        return state
    w = int(deb_order(state.f, state.phi)[-1])
    X, F, P = state.X.copy(), state.f.copy(), state.phi.copy()
    X[w], F[w], P[w] = U[c], f[c], phi[c]
    return dataclasses.replace(state, X=_frozen(X), f=_frozen(F), phi=_frozen(P), best=w)
