"""Structural moves on a feasible plan: the number of hover points changes (issue 14).

`restructure` is a first-improvement local search over waypoint removals (detour corners that
hover ~0 s), merges of two consecutive points, splits of one point in two and removals of one
point with a neighbour moved to clear the joining leg; `kicks` is an iterated local search that
moves one point at random. Every move is evaluated with its LP hover times (the map's access
model: `descent.lp_times`, the scheduled LP in scheduled access) and descended
(`planner_core.search.descent.descend`) in a race against the incumbent (`_move`; on a large
problem a move whose own evaluation is more than `RACE_FIRST` above the incumbent is not
descended), all through the caller's counted `evaluate`. Cost per move: its LP (I points x J
sensors) and up to `move_trials` evaluations; the move lists grow with I (merges, removals)
and with the sensors a point serves (splits).
"""

from __future__ import annotations

import itertools
from collections.abc import Iterator
from typing import Any

import numpy as np

from planner_core.model.formulas import deb_better
from planner_core.search.descent import (
    Descent,
    Evaluate,
    descend,
    hover_of,
    large_problem,
    lp_times,
)
from planner_core.search.polish import ZERO_TIME
from planner_core.search.trial import held_points
from planner_core.streams import stream_rng

__all__ = [
    "CLEAR_SHIFTS",
    "FIELD_MIN_STEP",
    "KICK",
    "MOVES",
    "RACE_FIRST",
    "kicks",
    "merge_moves",
    "move_min_step",
    "removal_moves",
    "restructure",
    "split_moves",
    "waypoint_moves",
]

#: the fractions of the way from a split point towards each half of its sensors (`split_moves`)
SPLIT_FRACTIONS = (0.3, 0.6, 1.0)
#: the share of a sensor's data Q_j a hover point must collect to count as serving it
SERVES = 0.05


def split_moves(problem: Any, P: np.ndarray, T: np.ndarray) -> list[np.ndarray]:
    """Point sets (I + 1, 2) with one hover point split in two: for each point serving two or
    more sensors (collecting >= `SERVES` of Q_j there), its sensors halved along their principal
    axis, and the point replaced by two points `SPLIT_FRACTIONS` of the way towards each half's
    centroid, in the order that makes the shorter path.

    Args:
        problem: the UAV `Problem`.
        P: hover points (I, 2), m.
        T: their hover times (I,), s.

    Returns:
        The point sets, point by point, fraction by fraction.
    """
    return list(_splits(problem, P, T))


def _splits(problem: Any, P: np.ndarray, T: np.ndarray) -> Iterator[np.ndarray]:
    """`split_moves` one at a time, in its order."""
    m = problem.model
    R = m.rates(P)
    for i in range(len(P)):
        served = np.flatnonzero(R[i] * T[i] >= SERVES * m.required)
        if len(served) < 2:
            continue
        S = m.sensors[served]
        c = S - S.mean(axis=0)
        proj = c @ np.linalg.svd(c, full_matrices=False)[2][0]
        cut = np.median(proj)
        a, b = S[proj <= cut].mean(axis=0), S[proj > cut].mean(axis=0)
        prev = P[i - 1] if i > 0 else problem.start
        nxt = P[i + 1] if i + 1 < len(P) else problem.end
        for frac in SPLIT_FRACTIONS:
            pa, pb = P[i] + frac * (a - P[i]), P[i] + frac * (b - P[i])
            if (np.linalg.norm(prev - pa) + np.linalg.norm(pb - nxt)
                    > np.linalg.norm(prev - pb) + np.linalg.norm(pa - nxt)):
                pa, pb = pb, pa
            yield np.vstack([P[:i], pa, pb, P[i + 1:]])


def waypoint_moves(P: np.ndarray, T: np.ndarray) -> list[np.ndarray]:
    """The point set (I', 2) without the points that hover ~0 s (`polish.ZERO_TIME`): detour
    corners, which `restructure` then routes afresh; none when there are no such points or
    nothing would be left.

    Args:
        P: hover points (I, 2), m.
        T: their hover times (I,), s.

    Returns:
        [P without them], or [].
    """
    keep = np.asarray(T) > ZERO_TIME
    return [P[keep]] if 0 < keep.sum() < len(P) else []


#: how far (m) `removal_moves` moves a neighbour of a removed point, smallest first
CLEAR_SHIFTS = (25.0, 50.0, 100.0, 200.0, 400.0)


def removal_moves(problem: Any, P: np.ndarray, T: np.ndarray) -> list[np.ndarray]:
    """Point sets (I - 1, 2) with one hover point removed, the points that hover least first
    (the detour corners, 0 s, lead): when the leg that then joins its two neighbours is clear
    and nothing is held (`held_points`: C3, C5), the set as it is; else one set per neighbouring
    hover point that, moved square to that leg by the smallest of `CLEAR_SHIFTS` to either
    side, leaves nothing held (the start and the end stay). Every point costs a stop (Eq. 1: a
    leg from rest to rest), a corner for nothing but the detour; `waypoint_moves` drops the
    corners but routes the legs afresh, which puts corners back wherever the neighbours stay
    where they are.

    Args:
        problem: the UAV `Problem`.
        P: hover points (I, 2), m.
        T: their hover times (I,), s.

    Returns:
        The point sets, in that order.
    """
    return list(_removals(problem, P, T))


def _removals(problem: Any, P: np.ndarray, T: np.ndarray) -> Iterator[np.ndarray]:
    """`removal_moves` one at a time, in its order: a first-improvement search that stops at
    the first better move checks the clearance (C3, C5) of no later one."""
    P = np.asarray(P, dtype=float).reshape(-1, 2)
    box = np.array([problem.model.width, problem.model.height])
    for c in np.argsort(np.asarray(T, dtype=float), kind="stable"):
        Q0 = np.delete(P, c, axis=0)
        if not len(Q0):
            continue
        if not len(held_points(problem, Q0)):
            yield Q0
            continue
        a = P[c - 1] if c > 0 else problem.start
        b = P[c + 1] if c + 1 < len(P) else problem.end
        u = b - a
        length = float(np.hypot(*u))
        if length <= 0.0:
            continue
        normal = np.array([-u[1], u[0]]) / length
        for k in (c - 1, c):  # the neighbours' indices in Q0
            if not 0 <= k < len(Q0):
                continue
            for shift in (s * d for d in CLEAR_SHIFTS for s in (1.0, -1.0)):
                Q = Q0.copy()
                Q[k] = np.clip(Q[k] + shift * normal, 0.0, box)
                if not len(held_points(problem, Q)):
                    yield Q
                    break


def merge_moves(P: np.ndarray) -> list[np.ndarray]:
    """Point sets (I - 1, 2) with two consecutive hover points replaced by their midpoint,
    the closest pairs first.

    Args:
        P: hover points (I, 2), m.

    Returns:
        I - 1 point sets (none for I < 2).
    """
    gaps = np.linalg.norm(np.diff(P, axis=0), axis=1)
    out = []
    for i in np.argsort(gaps, kind="stable"):
        Q = np.delete(P, i + 1, axis=0)
        Q[i] = 0.5 * (P[i] + P[i + 1])
        out.append(Q)
    return out


#: evaluations a move's descent gets before the race decides whether it goes on (`_move`)
RACE_SCREEN = 6
#: a move's descent goes on past `RACE_SCREEN` only if its plan is within this share of the
#: incumbent's f (0.3 %): most moves that end better than the incumbent are better after 2-7
#: evaluations, most that end worse never get close (docs/search.md, "Raced structural moves")
RACE_MARGIN = 0.003
#: on a large problem (`descent.large_problem`) a move whose own plan (its LP hover times, the
#: move's first evaluation) is more than this share above the incumbent's f (1 %) is not
#: descended: on L06, 155 of the 298 moves that lost were that far above and spent 1,123 of
#: the run's 5,730 move evaluations, 4 of the 44 that won (docs/search.md, "Per-point steps
#: and the first screen")
RACE_FIRST = 0.01


def _move(
    problem: Any, Q: np.ndarray, evaluate: Evaluate, trials: int, *, reroute: bool = False,
    incumbent: float | None = None,
) -> tuple[np.ndarray, float, float, int] | None:
    """Hover points Q (I, 2) as a plan: refused (None, no evaluation) when a point breaks C3 or
    C5 or a sensor cannot be served; else evaluated with its LP hover times (one evaluation)
    and descended with at most `trials` - 1 more. Returns (x (d,), f, phi, evaluations).
    `reroute`: a Q whose legs cut an obstacle first gets the seeder's visibility-graph corners
    on those legs (`Seeder.route`), kept when it then fits in I_max points. `incumbent`: the f
    of the plan the move competes with; then the descent is raced (cf. racing in algorithm
    configuration, Birattari et al., GECCO 2002): once it has spent `RACE_SCREEN` evaluations
    (after the move's own one) it goes on only if its plan's f is within `RACE_MARGIN` of
    `incumbent` (checked once; a descent that converges sooner ends there anyway), so the
    budget goes to the moves that can win; on a large problem (`descent.large_problem`) a move
    whose own evaluation is more than `RACE_FIRST` above `incumbent` is not descended at all."""
    m = problem.model
    held = len(held_points(problem, Q))
    if reroute and held:
        Q = np.asarray(problem.seeder.route(Q)[0], dtype=float).reshape(-1, 2)
        if not 0 < len(Q) <= problem.n_points:
            return None
        held = len(held_points(problem, Q))
    if held:
        return None
    T = lp_times(problem, m.rates(Q))
    if T is None:
        return None
    x = problem.encode(Q, T)
    f, phi = (float(np.asarray(v).reshape(-1)[0]) for v in evaluate(x[None, :]))
    if incumbent is not None and large_problem(problem) and f > incumbent * (1.0 + RACE_FIRST):
        return x, f, phi, 1  # out of the race at the first evaluation
    race = None if incumbent is None else (RACE_SCREEN, incumbent * (1.0 + RACE_MARGIN))
    r = descend(problem, x, evaluate, trials=trials - 1, race=race,
                min_step=move_min_step(problem))
    if r is None:
        return x, f, phi, 1
    return r.x, r.f, r.phi, 1 + r.evaluations


#: m: a move's descent on a large problem whose sensors lie in clustered fields or along a
#: corridor (`Problem.uniform_layout` False) stops once its steps fall below this, where the
#: descent's own `MIN_STEP` (1 cm) spends the last ~9 halvings, an evaluation each, on plans
#: that differ by centimetres: the evaluations go to more moves instead. Seeds 0-9 of L06, L07
#: and L08 (L05 0-3), paired with 1 cm: -0.92, -0.50, -0.85 (-0.72) % of f, 8-9 of 10 lower;
#: on the uniform maps (L01-L03) -0.06 to +0.03 %, so they keep 1 cm (docs/search.md,
#: "Coarser steps for the moves")
FIELD_MIN_STEP = 5.0


def move_min_step(problem: Any) -> float | None:
    """The least step (m) of a structural move's descent on `problem`: `FIELD_MIN_STEP` on a
    large problem (`descent.large_problem`) whose layout is not uniform
    (`Problem.uniform_layout`), else None (the descent's own `MIN_STEP`). The extra moves
    cost CPU (1.04-1.20x on L05-L08, 1.02-1.25x on two 500-sensor maps; L06 plans in 18.7x
    T16's time, within issue 31's 20x: docs/search.md, "Coarser steps for the moves").

    Args:
        problem: the UAV `Problem`.

    Returns:
        The step, m, or None.
    """
    if large_problem(problem) and not getattr(problem, "uniform_layout", True):
        return FIELD_MIN_STEP
    return None


#: the kinds of structural move `restructure` tries by default, in this order
MOVES = ("waypoint", "merge", "split")


def restructure(
    problem: Any, x: np.ndarray, evaluate: Evaluate, *, trials: int, move_trials: int = 40,
    moves: tuple[str, ...] = MOVES,
) -> Descent | None:
    """First-improvement local search over the plan's structure: each move of the kinds
    `moves`, in that order (default `waypoint_moves`, `merge_moves`, then `split_moves`: the
    moves that remove points first, so that on a large plan the many splits do not use up the
    budget before any merge is tried; "removal" is `removal_moves`; a move whose legs cut an
    obstacle is first re-routed through the visibility graph) that keeps every point
    within C3 and C5 and every sensor servable is evaluated with its LP hover times and
    descended in a race against the incumbent (`_move`, at most `move_trials` more
    evaluations); the first Deb-better result is kept and the moves are tried again from it,
    until none improves or `trials` evaluations are spent (all through `evaluate`).
    Variable-length plans only (the number of hover points changes; at most I_max);
    deterministic.

    Args:
        problem: the UAV `Problem`.
        x: a decision vector (d,).
        evaluate: the caller's counted evaluation.
        trials: the most evaluations.
        move_trials: a move's descent cap (after its own evaluation).
        moves: the kinds, in order: "waypoint", "merge", "split", "removal".

    Returns:
        The best plan found (`Descent`); None in the fixed-length mode, with tau <= 0 (every
        slot active), for an infeasible x or `trials` < 1.

    Raises:
        ValueError: an unknown kind of move.
    """
    kinds = {  # each kind's moves drawn one at a time: the search stops at the first better
        "waypoint": lambda P, T: waypoint_moves(P, T),
        "merge": lambda P, T: merge_moves(P),
        "split": lambda P, T: _splits(problem, P, T),
        "removal": lambda P, T: _removals(problem, P, T),
    }
    unknown = [k for k in moves if k not in kinds]
    if unknown:
        raise ValueError(f"moves: unknown kind {unknown[0]!r}, expected some of "
                         f"{', '.join(kinds)}")
    if not problem.variable_length or problem.tau <= 0.0 or trials < 1:
        return None
    x = np.asarray(x, dtype=float)
    b = problem.breakdown(x)
    if b["phi"] > 0:
        return None
    best_x, best_f, best_phi, f_start = x, float(b["f"]), 0.0, float(b["f"])
    P, T = hover_of(b)
    spent = 0
    improved = True
    while improved and spent < trials:
        improved = False
        for Q in itertools.chain.from_iterable(kinds[kind](P, T) for kind in moves):
            if spent >= trials:
                break
            if not 0 < len(Q) <= problem.n_points:
                continue
            tried = _move(problem, Q, evaluate, min(move_trials + 1, trials - spent),
                          reroute=True, incumbent=best_f)
            if tried is None:
                continue
            xq, fq, phiq, n = tried
            spent += n
            if deb_better(fq, phiq, best_f, best_phi):
                best_x, best_f, best_phi = xq, fq, phiq
                P, T = hover_of(problem.breakdown(xq))
                improved = True
                break
    return Descent(best_x, best_f, best_phi, spent, f_start)


#: the spread (m) of a kick: one hover point moved by a normal step of this standard deviation
#: per axis (a mean move of ~376 m)
KICK = 300.0
#: kicks drawn per evaluation allowed, at most: a kick into an obstacle, past the bandwidth or
#: leaving a sensor unserved is refused before any evaluation
KICK_ATTEMPTS = 4


def kicks(
    problem: Any, x: np.ndarray, evaluate: Evaluate, *, trials: int, seed: int,
    move_trials: int = 40, spread: float = KICK, stream: int = 0,
) -> Descent | None:
    """Iterated local search (Lourenco, Martin & Stuetzle, "Iterated local search", Handbook of
    Metaheuristics, 2003) around plan x (d,): one hover point, drawn at random, moved by a
    normal kick (standard deviation `KICK` m per axis), the plan evaluated with its LP hover
    times and descended in a race against the incumbent (`_move`, at most `move_trials`
    evaluations), kept when Deb-better;
    repeated until `trials` evaluations are spent (all through `evaluate`; a kick refused
    before evaluation, into an obstacle, past the bandwidth or leaving a sensor unserved, costs
    none; at most `KICK_ATTEMPTS` x `trials` kicks are drawn). `spread` (m): the kick's
    standard deviation per axis. Seeded: the same seed and `stream` (0: the final stage's own;
    the pipeline's later rounds pass their round) give the same plan.

    Args:
        problem: the UAV `Problem`.
        x: the plan (d,).
        evaluate: the caller's counted evaluation.
        trials: the most evaluations.
        seed: the run's seed.
        move_trials: a move's descent cap.
        spread: the kick's standard deviation per axis, m.
        stream: the random stream (0: the final stage's).

    Returns:
        The best plan found (`Descent`); None for an infeasible x, a plan without hover
        points or `trials` < 1.
    """
    m = problem.model
    rng = stream_rng(seed, "kicks", *((stream,) if stream else ()))
    box = np.array([m.width, m.height])

    def kick(P: np.ndarray, T: np.ndarray) -> np.ndarray:
        Q = P.copy()
        i = int(rng.integers(len(Q)))
        Q[i] = np.clip(Q[i] + rng.normal(0.0, float(spread), 2), 0.0, box)
        return Q

    return perturbation_search(problem, x, evaluate, kick, trials=trials,
                               attempts=KICK_ATTEMPTS, move_trials=move_trials)


def perturbation_search(
    problem: Any, x: np.ndarray, evaluate: Evaluate, draw: Any, *, trials: int,
    attempts: int, move_trials: int = 40, reroute: bool = False,
) -> Descent | None:
    """The loop `kicks` and `rebuild` (`planner_core.search.rebuild`) share: `draw(P, T)`
    perturbs the incumbent's hover points P (I, 2) (T (I,) their hover times) into new points
    Q, or returns None; Q is evaluated with its LP hover times and descended in a race against
    the incumbent (`_move`, at most `move_trials` more evaluations; `reroute`: legs through
    obstacles re-routed first) and kept when Deb-better; until `trials` evaluations are spent
    or `attempts` x `trials` draws made (a draw refused before evaluation costs none).

    Args:
        problem: the UAV `Problem`.
        x: the plan (d,).
        evaluate: the caller's counted evaluation.
        draw: (P, T) -> Q (I', 2) or None.
        trials: the most evaluations.
        attempts: draws per evaluation allowed.
        move_trials: a move's descent cap.
        reroute: re-route legs through obstacles before a move is scored.

    Returns:
        The best plan found (`Descent`); None for an infeasible x (d,), a plan without hover
        points or `trials` < 1.

    Cost: per draw, what `draw` costs plus a move's (one LP, O(I x J), and its descent).
    """
    x = np.asarray(x, dtype=float)
    b = problem.breakdown(x)
    if b["phi"] > 0 or trials < 1 or not b["hover_points"]:
        return None
    best_x, best_f, best_phi, f_start = x, float(b["f"]), 0.0, float(b["f"])
    P, T = hover_of(b)
    spent = 0
    for _ in range(attempts * trials):  # refused draws cost no evaluation: bounded apart
        if spent >= trials:
            break
        Q = draw(P, T)
        if Q is None:
            continue
        tried = _move(problem, Q, evaluate, min(move_trials + 1, trials - spent),
                      reroute=reroute, incumbent=best_f)
        if tried is None:
            continue
        xq, fq, phiq, n = tried
        spent += n
        if deb_better(fq, phiq, best_f, best_phi):
            best_x, best_f, best_phi = xq, fq, phiq
            P, T = hover_of(problem.breakdown(xq))
    return Descent(best_x, best_f, best_phi, spent, f_start)


