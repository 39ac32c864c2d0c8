"""Hover-point descent with exact hover times: a local search on a plan's hover points (issue 14).

For fixed hover points P (I, 2) the least total hover time that serves every sensor is the LP of
`planner_core.polish` (`hover_lp`), so the best objective a plan with these points can have is

    F(P) = alpha * t_fly(P) + (1 - alpha) * V(P),

t_fly the Eq. 1 flight time of start -> P -> end and V the LP's value (the hover times "in the
loop", as the issue asks, instead of searched alongside the positions as the DE does). F is
piecewise smooth and its gradient is exact where the LP's optimum is non-degenerate:

* flight: d t_leg / d len = 1 / v_max on a cruising leg (len > v_max^2 / a), 1 / sqrt(a len) on
  a triangular one (Eq. 1 differentiated); d len / d p is the leg's unit vector;
* hover: LP sensitivity to the constraint matrix, dV/dR_ij = -y_j T_i / Q_j (y the coverage
  rows' duals, `hover_lp`), with dR_ij/dp_i = -xi (p_i - s_j) / sqrt(|p_i - s_j|^2 + H^2) where
  R_ij > 0 (the link model of Sec. 3).

A step moves every point against the gradient, the largest move `step` metres. A point whose new
position breaks C3 (summed link rate over the bandwidth) or whose legs cut an obstacle (C5, the
evaluator's `L_VIO_TOL`) takes its step turned by +-45 degrees and shortened to its projection
instead (`_slide`: it slides along the obstacle, where the optimum often lies, with a leg
tangent to it), or, where neither clears, is held in place for that trial; the trial is then
evaluated (one evaluation of the caller's counted `evaluate`) and kept when it is Deb-better
than the current plan. `step` grows 1.5x after a kept trial and halves after a rejected one (a
backtracking line search); the descent stops at `min_step` or after `trials` evaluations. Every
kept plan is feasible and its f is what the evaluator says, so the result is never worse than
the start.

The descent keeps the number of points and their visiting order; `plan` runs it on the best
constructive and seeded starts before the DE and on the plan after the polish (docs/search.md).
`objective` is the fast path; `objective_reference` recomputes F alone through the polish's own
LP for the tests' finite-difference check.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from planner_core.geometry import overlap_lengths
from planner_core.model import L_VIO_TOL, deb_better
from planner_core.polish import ZERO_TIME, hover_lp

__all__ = [
    "CLEAR_SHIFTS",
    "Descent",
    "MOVES",
    "SLIDE_ANGLES",
    "descend",
    "final_budget",
    "final_shares",
    "final_stage",
    "finish",
    "kicks",
    "held_points",
    "merge_moves",
    "objective",
    "objective_reference",
    "other_structure",
    "removal_moves",
    "restructure",
    "split_moves",
    "waypoint_moves",
]

#: first step (m): the largest point move of the first trial
STEP = 20.0
#: the descent stops when the step falls below this (m)
MIN_STEP = 0.01
#: growth and shrink factors of the step after a kept / rejected trial
GROW, SHRINK = 1.5, 0.5

Evaluate = Callable[[np.ndarray], tuple[np.ndarray, np.ndarray]]


@dataclass(frozen=True)
class Descent:
    """A descent's result: the decision vector x (d,) of the best plan found (points, LP hover
    times topped up to meet C4 exactly), its evaluated f and phi, how many evaluations it spent,
    and the f it started from; for `finish` with a second plan also that plan's number of
    hover points (0: none was finished), whether its result was kept and the evaluations it
    spent (counted in `evaluations` too)."""

    x: np.ndarray
    f: float
    phi: float
    evaluations: int
    f_start: float
    other_points: int = 0
    other_won: bool = False
    other_evaluations: int = 0


def _hover(b: dict[str, Any]) -> tuple[np.ndarray, np.ndarray]:
    """Hover points (I, 2) m and times (I,) s of a `Problem.breakdown` dict."""
    return (np.asarray(b["hover_points"], dtype=float).reshape(-1, 2),
            np.asarray(b["hover_times"], dtype=float))


def final_budget(room: int, trials: int) -> int:
    """Evaluations the final plan's `finish` gets: `trials`, at most a tenth of `room` (the
    budget less the population and the polish's plans, before the starts and the final stage
    are taken off the DE); `plan` and the benchmark's `planner` entry both use it."""
    return min(int(trials), int(room) // 10)


def final_shares(final: int, own: int, other: bool, least: int) -> tuple[int, int]:
    """How `plan` and the benchmark's `planner` entry split the final stage's `final`
    evaluations: (the final plan's, the second plan's). The final plan's own share `own`
    first; the second plan (`other`: whether `other_structure` found one) gets the rest only
    when that is at least `least` (a descent's trials: less would not even descend it), else
    the final plan gets all of it."""
    mine = min(int(own), int(final))
    if not other or final - mine < least:
        return int(final), 0
    return mine, int(final) - mine


def _nodes(problem: Any, P: np.ndarray) -> np.ndarray:
    return np.vstack([problem.start, P, problem.end])


def objective(
    problem: Any, P: np.ndarray, warm: dict[Any, Any] | None = None
) -> tuple[float, np.ndarray, np.ndarray] | None:
    """F(P) (s), its gradient dF/dP (I, 2) (s/m) and the LP hover times T (I,) (s) for hover
    points P (I, 2) in metres; None when no hover times serve every sensor (the LP is
    infeasible). `warm`: the LP's warm-start store (`polish.hover_lp`). Module docstring for
    the formulas."""
    P = np.asarray(P, dtype=float).reshape(-1, 2)
    m = problem.model
    R = m.rates(P)
    lp = hover_lp(R, m.required, m.t_max, warm)
    if lp is None:
        return None
    T, V, y = lp
    nodes = _nodes(problem, P)
    seg = np.diff(nodes, axis=0)
    d = np.hypot(seg[:, 0], seg[:, 1])
    t_fly = float(m.flight_time(d).sum())
    # Eq. 1 differentiated: cruise 1 / v_max, triangle 1 / sqrt(a d) (zero-length legs: 0)
    dtdd = np.where(d > m.v_max**2 / m.accel, 1.0 / m.v_max,
                    1.0 / np.sqrt(m.accel * np.maximum(d, 1e-12)))
    u = np.where(d[:, None] > 0, seg / np.maximum(d, 1e-300)[:, None], 0.0) * dtdd[:, None]
    g_fly = u[:-1] - u[1:]  # point i ends leg i and starts leg i + 1
    need = m.required > 0
    diff = P[:, None, :] - m.sensors[None, need]
    slant = np.sqrt((diff**2).sum(axis=-1) + m.altitude**2)
    dR = -m.decay * diff / slant[..., None] * (R[:, need] > 0)[..., None]
    w = y[need] / m.required[need]
    g_hover = -(T[:, None, None] * w[None, :, None] * dR).sum(axis=1)
    g = m.alpha * g_fly + (1.0 - m.alpha) * g_hover
    return m.alpha * t_fly + (1.0 - m.alpha) * V, g, T


def objective_reference(problem: Any, P: np.ndarray) -> float:
    """F(P) alone, the obvious way: the polish's own LP for the hover times (no drop of points),
    the flight time leg by leg; what `objective` computes with its gradient."""
    P = np.asarray(P, dtype=float).reshape(-1, 2)
    m = problem.model
    from planner_core.polish import _solve_lp

    T, _ = _solve_lp(m.rates(P), m.required, m.t_max, True, "linprog")
    nodes = _nodes(problem, P)
    legs = zip(nodes[:-1], nodes[1:], strict=True)
    t_fly = sum(float(m.flight_time(np.linalg.norm(b - a))) for a, b in legs)
    return m.alpha * t_fly + (1.0 - m.alpha) * float(T.sum())


def held_points(problem: Any, P: np.ndarray) -> np.ndarray:
    """Indices of the hover points P (I, 2) that break C3 (summed link rate above the
    bandwidth) or end or start a leg that cuts an obstacle by more than `L_VIO_TOL` (C5)."""
    m = problem.model
    bad = m.rates(P).sum(axis=1) > m.bandwidth
    nodes = _nodes(problem, P)
    cut = overlap_lengths(nodes[:-1], nodes[1:], problem.obstacles) > L_VIO_TOL
    bad |= cut[:-1] | cut[1:]  # leg k ends at point k and leg k + 1 starts there
    return np.flatnonzero(bad)


#: the turns (degrees) a held point's step tries, in this order, each shortened to its
#: projection (cos 45 deg): the point slides along the obstacle or the bandwidth limit
SLIDE_ANGLES = (45.0, -45.0)
_SLIDE = np.array([np.cos(a) * np.array([[np.cos(a), -np.sin(a)], [np.sin(a), np.cos(a)]])
                   for a in np.radians(SLIDE_ANGLES)])  # (A, 2, 2): turn by a, scale by cos a


def _slide(
    problem: Any, P: np.ndarray, Pn: np.ndarray, move: np.ndarray, held: np.ndarray,
    box: np.ndarray,
) -> np.ndarray:
    """The trial points Pn (I, 2) with each held point (`held`, indices) moved by its step
    `move` (I, 2) turned by the first of `SLIDE_ANGLES` whose two legs clear the obstacles
    (C5) and whose summed link rate stays within the bandwidth (C3), or put back at P where
    none does. A held point's legs are checked against its previous neighbour after the
    held points are put back and its next neighbour at its own step; `descend` then holds
    whatever still breaks C3 or C5. One vectorised check for all held points and turns (a
    crude cousin of Rosen's gradient projection, exact only when the obstacle's edge lies at
    45 degrees to the step)."""
    m = problem.model
    k, a = len(held), len(_SLIDE)
    ahead = _nodes(problem, Pn)  # every point at its step
    Pn = Pn.copy()
    Pn[held] = P[held]
    back = _nodes(problem, Pn)  # the held points put back
    cand = np.clip(P[held][:, None, :] + np.einsum("aij,kj->kai", _SLIDE, move[held]), 0.0, box)
    c = cand.reshape(-1, 2)
    prev, nxt = np.repeat(back[held], a, axis=0), np.repeat(ahead[held + 2], a, axis=0)
    cut = overlap_lengths(np.vstack([prev, c]), np.vstack([c, nxt]), problem.obstacles) > L_VIO_TOL
    bad = (cut[: k * a] | cut[k * a:] | (m.rates(c).sum(axis=1) > m.bandwidth)).reshape(k, a)
    first = np.argmax(~bad, axis=1)
    ok = ~bad[np.arange(k), first]
    Pn[held[ok]] = cand[np.arange(k)[ok], first[ok]]
    return Pn


def descend(
    problem: Any,
    x: np.ndarray,
    evaluate: Evaluate,
    *,
    trials: int,
    step: float = STEP,
    min_step: float = MIN_STEP,
    race: tuple[int, float] | None = None,
) -> Descent | None:
    """Descend from plan x (d,) of the UAV problem `problem` for at most `trials` evaluations.

    `evaluate` (X (n, d) -> f, phi) is the caller's counted evaluation; the start itself is not
    re-evaluated (its f is recomputed from the LP). `race` (n, limit): once n evaluations are
    spent the descent stops unless its best f is <= limit (checked once; `_move`'s race).
    Returns None when x is not a feasible plan with at least one hover point, or when
    `trials` < 1. Deterministic (no random numbers).
    """
    b = problem.breakdown(np.asarray(x, dtype=float))
    P = _hover(b)[0]
    if b["phi"] > 0 or len(P) == 0 or trials < 1 or len(held_points(problem, P)):
        return None
    warm: dict[Any, Any] = {}  # this descent's own LP warm starts: reproducible
    cur = objective(problem, P, warm)
    if cur is None:
        return None
    g = cur[1]
    f_start = float(b["f"])
    best_x, best_f, best_phi = np.asarray(x, dtype=float), f_start, 0.0
    box = np.array([problem.model.width, problem.model.height])
    spent = 0
    while spent < trials and step >= min_step:
        if race is not None and spent == race[0] and best_f > race[1]:
            break  # out of the race
        scale = float(np.abs(g).max())
        if scale <= 0.0:
            break
        move = -g / scale * step
        Pn = np.clip(P + move, 0.0, box)
        held = held_points(problem, Pn)
        if len(held):
            Pn = _slide(problem, P, Pn, move, held, box)
            for _ in range(len(P)):  # what still breaks C3 or C5 stays where it was
                held = held_points(problem, Pn)
                if not len(held):
                    break
                Pn[held] = P[held]
        kept = False
        if not len(held) and not np.array_equal(Pn, P):
            nxt = objective(problem, Pn, warm)
            if nxt is not None:
                xn = problem.encode(Pn, nxt[2])
                fn, phin = evaluate(xn[None, :])
                spent += 1
                fn = float(np.asarray(fn).reshape(-1)[0])
                phin = float(np.asarray(phin).reshape(-1)[0])
                if deb_better(fn, phin, best_f, best_phi):
                    P, g = Pn, nxt[1]
                    best_x, best_f, best_phi = xn, fn, phin
                    kept = True
        step = step * GROW if kept else step * SHRINK
    return Descent(best_x, best_f, best_phi, spent, f_start)


# ----------------------------------------------------------------------------- structural moves
#: the fractions of the way from a split point towards each half of its sensors (`split_moves`)
SPLIT_FRACTIONS = (0.3, 0.6, 1.0)
#: the share of a sensor's data Q_j a hover point must collect to count as serving it
SERVES = 0.05


def split_moves(problem: Any, P: np.ndarray, T: np.ndarray) -> list[np.ndarray]:
    """Point sets (I + 1, 2) with one hover point split in two: for each point serving two or
    more sensors (collecting >= `SERVES` of Q_j there), its sensors halved along their principal
    axis, and the point replaced by two points `SPLIT_FRACTIONS` of the way towards each half's
    centroid, in the order that makes the shorter path. P (I, 2) m, T (I,) s."""
    m = problem.model
    R = m.rates(P)
    out = []
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
            out.append(np.vstack([P[:i], pa, pb, P[i + 1:]]))
    return out


def waypoint_moves(P: np.ndarray, T: np.ndarray) -> list[np.ndarray]:
    """The point set (I', 2) without the points that hover ~0 s (`polish.ZERO_TIME`): detour
    corners, which `restructure` then routes afresh; none when there are no such points or
    nothing would be left. P (I, 2) m, T (I,) s."""
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
    where they are. P (I, 2) m, T (I,) s."""
    P = np.asarray(P, dtype=float).reshape(-1, 2)
    box = np.array([problem.model.width, problem.model.height])
    out = []
    for c in np.argsort(np.asarray(T, dtype=float), kind="stable"):
        Q0 = np.delete(P, c, axis=0)
        if not len(Q0):
            continue
        if not len(held_points(problem, Q0)):
            out.append(Q0)
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
                    out.append(Q)
                    break
    return out


def merge_moves(P: np.ndarray) -> list[np.ndarray]:
    """Point sets (I - 1, 2) with two consecutive hover points replaced by their midpoint,
    the closest pairs first. P (I, 2) m."""
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
    budget goes to the moves that can win."""
    m = problem.model
    held = len(held_points(problem, Q))
    if reroute and held:
        Q = np.asarray(problem.seeder.route(Q)[0], dtype=float).reshape(-1, 2)
        if not 0 < len(Q) <= problem.n_points:
            return None
        held = len(held_points(problem, Q))
    if held:
        return None
    lp = hover_lp(m.rates(Q), m.required, m.t_max)
    if lp is None:
        return None
    x = problem.encode(Q, lp[0])
    f, phi = (float(np.asarray(v).reshape(-1)[0]) for v in evaluate(x[None, :]))
    race = None if incumbent is None else (RACE_SCREEN, incumbent * (1.0 + RACE_MARGIN))
    r = descend(problem, x, evaluate, trials=trials - 1, race=race)
    if r is None:
        return x, f, phi, 1
    return r.x, r.f, r.phi, 1 + r.evaluations


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
    until none improves or `trials` evaluations are spent (all through `evaluate`). Raises
    ValueError for an unknown kind of move.

    Variable-length plans only (the number of hover points changes; at most I_max): returns
    None in the fixed-length mode, with tau <= 0 (every slot active), for an infeasible x or
    `trials` < 1. x (d,) a decision vector; deterministic.
    """
    kinds = {
        "waypoint": lambda P, T: waypoint_moves(P, T),
        "merge": lambda P, T: merge_moves(P),
        "split": lambda P, T: split_moves(problem, P, T),
        "removal": lambda P, T: removal_moves(problem, P, T),
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
    P, T = _hover(b)
    spent = 0
    improved = True
    while improved and spent < trials:
        improved = False
        for Q in [Q for kind in moves for Q in kinds[kind](P, T)]:
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
                P, T = _hover(problem.breakdown(xq))
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
    move_trials: int = 40,
) -> Descent | None:
    """Iterated local search (Lourenco, Martin & Stuetzle, "Iterated local search", Handbook of
    Metaheuristics, 2003) around plan x (d,): one hover point, drawn at random, moved by a
    normal kick (standard deviation `KICK` m per axis), the plan evaluated with its LP hover
    times and descended in a race against the incumbent (`_move`, at most `move_trials`
    evaluations), kept when Deb-better;
    repeated until `trials` evaluations are spent (all through `evaluate`; a kick refused
    before evaluation, into an obstacle, past the bandwidth or leaving a sensor unserved, costs
    none; at most `KICK_ATTEMPTS` x `trials` kicks are drawn). Seeded: the same seed gives the
    same plan. None for an infeasible x or `trials` < 1."""
    x = np.asarray(x, dtype=float)
    b = problem.breakdown(x)
    if b["phi"] > 0 or trials < 1 or not b["hover_points"]:
        return None
    m = problem.model
    rng = np.random.default_rng(np.random.SeedSequence([int(seed), 17]))
    box = np.array([m.width, m.height])
    best_x, best_f, best_phi, f_start = x, float(b["f"]), 0.0, float(b["f"])
    P = _hover(b)[0]
    spent = 0
    for _ in range(KICK_ATTEMPTS * trials):  # refused kicks cost no evaluation: bounded apart
        if spent >= trials:
            break
        Q = P.copy()
        i = int(rng.integers(len(Q)))
        Q[i] = np.clip(Q[i] + rng.normal(0.0, KICK, 2), 0.0, box)
        tried = _move(problem, Q, evaluate, min(move_trials + 1, trials - spent),
                      incumbent=best_f)
        if tried is None:
            continue
        xq, fq, phiq, n = tried
        spent += n
        if deb_better(fq, phiq, best_f, best_phi):
            best_x, best_f, best_phi = xq, fq, phiq
            P = _hover(problem.breakdown(xq))[0]
    return Descent(best_x, best_f, best_phi, spent, f_start)


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
    second structure"). None when x is not a feasible plan or `trials` < 1."""
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
    """The first row of `starts` (k, d), decision vectors best first (`construct.best_starts`'s
    order), that is a feasible plan with fewer hover points than plan x (d,), else the first
    with more; None when there is none (or no starts). Fewer first: every point costs a stop,
    the structural search splits a point more easily than it removes one, and on T06 and T07
    the final plans that end well above the best-known are those with more points (on
    `plan`'s seeds 0-24 of T06 fewer-first gave +0.52 % against +0.68 % for the best start of
    any other size; 8 seeds x 16 maps: T11 0.19 -> 0.16 %, T15 0.42 -> 0.44 %, the rest
    within 0.01 %)."""
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


def final_stage(
    problem: Any,
    x: np.ndarray,
    evaluate: Evaluate,
    *,
    final: int,
    own: int,
    starts: np.ndarray | None,
    seed: int,
    descent_trials: int | None = None,
    restructure_trials: int | None = None,
) -> Descent | None:
    """The final stage of `plan` and of the benchmark's `planner` entry on the polished plan x
    (d,): the second structure from `starts` (`other_structure`), the `final` evaluations split
    between the two plans (`final_shares`: x's own share `own` first; the second plan only when
    a descent's trials are left for it), then `finish`. `descent_trials`,
    `restructure_trials`: as `finish` (None: the defaults table's)."""
    from planner_core.defaults import DESCENT_TRIALS

    least = DESCENT_TRIALS if descent_trials is None else int(descent_trials)
    other = other_structure(problem, starts, x)
    mine, theirs = final_shares(final, own, other is not None, least)
    return finish(problem, x, evaluate, trials=mine, seed=seed, descent_trials=descent_trials,
                  restructure_trials=restructure_trials, other=other if theirs else None,
                  other_trials=theirs)


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
