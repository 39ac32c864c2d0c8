"""The final stage on the incumbent plan: descent, structural search, removal moves and kicks
(`finish`), on the incumbent and on a second plan of another structure (`other_structure`).

The pipeline (`planner_core.pipeline`) runs it after the polish, and again from other
structures and fresh constructive plans while budget is left. Cost: that of its parts
(`planner_core.search.descent`, `planner_core.search.structure`), bounded by `trials`
evaluations.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from planner_core.model.formulas import deb_better
from planner_core.search.descent import Descent, Evaluate, descend
from planner_core.search.structure import MOVES, kicks, restructure

__all__ = ["finish", "other_structure"]

def finish(
    problem: Any,
    x: np.ndarray,
    evaluate: Evaluate,
    *,
    trials: int,
    seed: int = 0,
    descent_trials: int | None = None,
    restructure_trials: int | None = None,
    other: np.ndarray | None = None,
    other_trials: int = 0,
) -> Descent | None:
    """What `plan` does to its final plan x (d,): `descend` (at most `descent_trials`
    evaluations; None: the defaults table's `DESCENT_TRIALS`), `restructure` (at most
    `restructure_trials`; None: `RESTRUCTURE_TRIALS`), `restructure` with the removal moves
    alone (`removal_moves`, a removed point's leg cleared by moving a neighbour; at most
    `restructure_trials` again), then `kicks` with what is left of `trials` (seeded by `seed`).

    `other` (d,): a second plan of another structure (`other_structure`: the best kept start
    with fewer, else more, hover points than x), finished the same way with at most
    `other_trials` more evaluations; the Deb-better of the two results is returned, with the
    evaluations of both and x's f as the start (`other_points`, `other_won` and
    `other_evaluations` say what the second plan was, whether it won and what it spent). The
    local moves rarely turn one structure into the other (merges and removals take one point
    at a time, each raced against the incumbent): on T06 the final plans with 7-9 points end
    1.2-1.9 % above the best-known and those with 4-6 points 0.1-0.4 % (docs/search.md, "A
    second structure").

    Args:
        problem: the UAV `Problem`.
        x: the plan (d,), problem space.
        evaluate: the caller's counted evaluation.
        trials: evaluations for x's finish.
        seed: the kicks' seed.
        descent_trials: the descent's cap (None: `DESCENT_TRIALS`).
        restructure_trials: each structural search's cap (None: `RESTRUCTURE_TRIALS`).
        other: the second plan (d,), or None.
        other_trials: evaluations for its finish (< 1: not finished).

    Returns:
        The `Descent`; None when x is not a feasible plan or `trials` < 1 (or anything else
        that makes `descend` refuse it: no hover point, a point `held_points` holds, 0
        descent trials); the second plan's finish is left out when `descend` refuses it.
    """
    cur = _finish_one(problem, x, evaluate, trials=trials, seed=seed,
                      descent_trials=descent_trials, restructure_trials=restructure_trials)
    if cur is None or other is None or other_trials < 1:
        return cur
    alt = _finish_one(problem, other, evaluate, trials=other_trials, seed=seed,
                      descent_trials=descent_trials, restructure_trials=restructure_trials)
    if alt is None:
        return cur
    won = deb_better(alt.f, alt.phi, cur.f, cur.phi)
    best = alt if won else cur
    n = len(problem.breakdown(np.asarray(other, dtype=float))["hover_points"])
    return Descent(best.x, best.f, best.phi, cur.evaluations + alt.evaluations, cur.f_start,
                   other_points=n, other_won=won, other_evaluations=alt.evaluations)


def other_structure(problem: Any, starts: np.ndarray | None, x: np.ndarray) -> np.ndarray | None:
    """The first row of `starts` (k, d), decision vectors best first (the pipeline passes its
    pool in Deb order), that is a feasible plan with fewer hover points than plan x (d,), else
    the first with more; None when there is none (or no starts). Fewer first: every point
    costs a stop, the structural search splits a point more easily than it removes one, and on
    T06 and T07
    the final plans that end well above the best-known are those with more points (on
    `plan`'s seeds 0-24 of T06 fewer-first gave +0.52 % against +0.68 % for the best start of
    any other size; 8 seeds x 16 maps: T11 0.19 -> 0.16 %, T15 0.42 -> 0.44 %, the rest
    within 0.01 %).

    Args:
        problem: the UAV `Problem`.
        starts: decision vectors (k, d), best first, or None.
        x: the plan (d,).

    Returns:
        A row of `starts` (d,), or None.
    """
    if starts is None or not len(starts):
        return None
    n = len(problem.breakdown(np.asarray(x, dtype=float))["hover_points"])
    more = None
    for s in np.asarray(starts, dtype=float):
        b = problem.breakdown(s)
        k = len(b["hover_points"])
        if b["phi"] > 0 or k in (0, n):
            continue
        if k < n:
            return s
        if more is None:
            more = s
    return more


def _finish_one(
    problem: Any,
    x: np.ndarray,
    evaluate: Evaluate,
    *,
    trials: int,
    seed: int,
    descent_trials: int | None,
    restructure_trials: int | None,
) -> Descent | None:
    """`finish` on one plan (its docstring)."""
    from planner_core.defaults import DESCENT_TRIALS, RESTRUCTURE_TRIALS

    d_trials = DESCENT_TRIALS if descent_trials is None else int(descent_trials)
    r_trials = RESTRUCTURE_TRIALS if restructure_trials is None else int(restructure_trials)
    cur = descend(problem, x, evaluate, trials=min(d_trials, trials))
    if cur is None:
        return None
    spent, f_start = cur.evaluations, cur.f_start
    for moves in (MOVES, ("removal",)):
        nxt = restructure(problem, cur.x, evaluate, trials=min(r_trials, trials - spent),
                          moves=moves)
        if nxt is not None:
            spent += nxt.evaluations
            cur = nxt
    nxt = kicks(problem, cur.x, evaluate, trials=trials - spent, seed=seed)
    if nxt is not None:
        spent += nxt.evaluations
        cur = nxt
    return Descent(cur.x, cur.f, cur.phi, spent, f_start)

