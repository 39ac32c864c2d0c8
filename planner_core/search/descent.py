"""Hover-point descent with exact hover times: a local search on a plan's hover points (issue 14).

For fixed hover points P (I, 2) the least total hover time that serves every sensor is the LP of
`planner_core.search.polish` (`hover_lp`), so the best objective a plan with these points can have
is

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
instead (it slides along the obstacle, where the optimum often lies, with a leg tangent to
it), or, where neither clears, is held in place for that trial (`planner_core.search.trial`);
the trial is then evaluated (one evaluation of the caller's counted `evaluate`) and kept when
it is Deb-better than the current plan. `step` grows 1.5x after a kept trial and halves after
a rejected one (a backtracking line search); the descent stops at `min_step` or after `trials`
evaluations. Every kept plan is feasible and its f is what the evaluator says, so the result
is never worse than the start.

Per-point steps (`PER_POINT`, the default on problems of more than `PAPER_POINTS` hover slots,
`large_problem`): one step length per point instead of one for all, adapted as Rprop adapts
its per-weight steps (Riedmiller & Braun, "A direct adaptive method for faster
backpropagation learning: the RPROP algorithm", ICNN 1993): point i moves `s_i` metres against
its own gradient; after a kept trial s_i grows by `RPROP_UP` (1.2) where the point's gradient
kept its direction (positive dot product with the last one) and shrinks by `RPROP_DOWN` (0.5)
where it turned; a rejected trial halves every s_i; the descent stops when the largest s_i
falls below `min_step`. A point whose step would break C3 is first projected back onto
its bandwidth limit along the summed rate's gradient, at most its step's length back
(`planner_core.search.trial.project_c3`: on a dense clustered field every point sits on that
limit and the gradient pulls it across, so without the projection it would stay put; its
move is then where that line meets the limit, not s_i); a point a trial still holds in place
(C3 or C5) keeps its gradient's direction, so its step grows with the kept trials and it
tries further the next time. With
one step for all, the point with the steepest gradient sets every point's move. Descent by
descent the two rules are about even (`benchmarks/bench_descent.py`: from kicked plans and
from constructive starts of L06 and L08 each ends lower about half the time); over whole
runs of the 240-400-sensor maps the per-point steps ended lower on 8 of 10 seeds of each
(docs/search.md, "Per-point steps and the first screen").

Scheduled access (`radio.access`): V is the scheduled hover-time LP's
(`polish.scheduled_hover_lp`: the data D_ij a point takes from each sensor are variables, no
C3), and dV/dR_ij = -L_ij T_i with L the duals of its link rows D_ij <= R_ij T_i
(`planner_core.model.hoverlp.scheduled_lp_links`) in place of y_j / Q_j; the trial points are
screened for C5 alone (`ModelParams.c3_limit`).

The descent keeps the number of points and their visiting order; the pipeline
(`planner_core.pipeline`) runs it on the best constructive and seeder plans before the DE and,
inside the final stage (`planner_core.search.final`), on the incumbent (docs/search.md).
Cost: one LP over I points x J sensors per trial (HiGHS, warm-started) and one evaluation;
the C3/C5 checks grow with I x J and with I x the obstacles' vertices.
`objective` is the fast path; `objective_reference` recomputes F alone through the polish's own
LP for the tests' finite-difference check.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np
from numba import njit

from planner_core.model.formulas import deb_better, leg_time
from planner_core.search.polish import hover_lp, scheduled_hover_lp
from planner_core.search.trial import (
    TRIAL_OK,
    held_points,
    path_nodes,
    project_c3,
    trial_points,
)

__all__ = [
    "GLOBAL",
    "PAPER_POINTS",
    "PER_POINT",
    "STEP_RULES",
    "Descent",
    "Evaluate",
    "descend",
    "hover_of",
    "large_problem",
    "lp_times",
    "objective",
    "gradient_reference",
    "objective_reference",
]

#: first step (m): the largest point move of the first trial
STEP = 20.0
#: the descent stops when the step falls below this (m)
MIN_STEP = 0.01
#: growth and shrink factors of the step after a kept / rejected trial
GROW, SHRINK = 1.5, 0.5
#: the paper's largest I_max (Sec. 5: 10 hover points on the 5 km maps, 20 on the 10 km ones):
#: a problem with more hover slots is large (`large_problem`)
PAPER_POINTS = 20
#: the step rules of `descend`: one step for every point, or one per point (module docstring)
GLOBAL, PER_POINT = "global", "per-point"
STEP_RULES = (GLOBAL, PER_POINT)
#: per-point steps: growth where a point's gradient keeps its direction after a kept trial,
#: shrink where it turns (Rprop's eta+ and eta-)
RPROP_UP, RPROP_DOWN = 1.2, 0.5


def large_problem(problem: Any) -> bool:
    """Whether `problem` allows more hover points than the paper's maps (`Problem.hover_limit`
    > `PAPER_POINTS`; corner slots not counted): its descents take per-point steps, its moves
    a first screen (`planner_core.search.structure._move`), and its default improving rounds
    are the large ones (`planner_core.pipeline.schedule.large_rounds`).

    Args:
        problem: the UAV `Problem` (its `hover_limit` read).

    Returns:
        True when hover_limit > `PAPER_POINTS`.
    """
    return int(problem.hover_limit) > PAPER_POINTS

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


def hover_of(b: dict[str, Any]) -> tuple[np.ndarray, np.ndarray]:
    """Hover points and times of a plan.

    Args:
        b: a `Problem.breakdown` dict ("hover_points", "hover_times" read).

    Returns:
        (P (I, 2) m, T (I,) s).
    """
    return (np.asarray(b["hover_points"], dtype=float).reshape(-1, 2),
            np.asarray(b["hover_times"], dtype=float))


def objective(
    problem: Any, P: np.ndarray, warm: dict[Any, Any] | None = None,
    R: np.ndarray | None = None,
) -> tuple[float, np.ndarray, np.ndarray] | None:
    """F(P), its gradient and the LP hover times. Module docstring for the formulas.

    Args:
        problem: the UAV `Problem`.
        P: hover points (I, 2), m.
        warm: the LP's warm-start store (`polish.hover_lp`), or None.
        R: the points' link rates (I, J) Mbit/s, when the caller has them.

    Returns:
        (F (s), dF/dP (I, 2) s/m, T (I,) s); None when no hover times serve every sensor
        (the LP is infeasible).
    """
    P = np.asarray(P, dtype=float).reshape(-1, 2)
    m = problem.model
    if R is None:
        R = m.rates(P)
    if getattr(problem, "scheduled", False):
        return _objective_scheduled(problem, P, R)
    lp = hover_lp(R, m.required, m.t_max, warm)
    if lp is None:
        return None
    T, V, y = lp
    t_fly, g = _flight_and_gradient(P, problem.start, problem.end, m.sensors, m.required, R,
                                    T, y, m.altitude, m.decay, m.v_max, m.accel, m.alpha)
    return m.alpha * t_fly + (1.0 - m.alpha) * V, g, T


def lp_times(problem: Any, R: np.ndarray) -> np.ndarray | None:
    """The hover times (I,) s a move's points get (`planner_core.search.structure._move`):
    the hover-time LP of the problem's access model, `hover_lp` (simultaneous, the paper's)
    or `polish.scheduled_hover_lp` (`radio.access` "scheduled").

    Args:
        problem: the UAV `Problem`.
        R: the points' link rates (I, J), Mbit/s.

    Returns:
        T (I,) s, or None when no hover times serve every sensor.
    """
    m = problem.model
    lp = (scheduled_hover_lp(problem, R) if getattr(problem, "scheduled", False)
          else hover_lp(R, m.required, m.t_max))
    return None if lp is None else lp[0]


def _objective_scheduled(
    problem: Any, P: np.ndarray, R: np.ndarray
) -> tuple[float, np.ndarray, np.ndarray] | None:
    """`objective` in scheduled access: V and T from `polish.scheduled_hover_lp`, the hover
    term of the gradient from its per-pair weights L (dV/dR_ij = -L_ij T_i in place of
    -y_j T_i / Q_j; the flight term as `_flight_and_gradient`'s, called with no duals)."""
    m = problem.model
    lp = scheduled_hover_lp(problem, R)
    if lp is None:
        return None
    T, V, L = lp
    t_fly, g = _flight_and_gradient(P, problem.start, problem.end, m.sensors, m.required, R,
                                    T, np.zeros(len(m.required)), m.altitude, m.decay,
                                    m.v_max, m.accel, m.alpha)
    i, j = np.nonzero((L > 0.0) & (R > 0.0))
    if len(i):
        diff = P[i] - m.sensors[j]
        slant = np.sqrt((diff**2).sum(axis=1) + m.altitude**2)
        w = (T[i] * L[i, j] * m.decay / slant)[:, None] * diff  # -dV/dR_ij x dR_ij/dp_i
        np.add.at(g, i, (1.0 - m.alpha) * w)
    return m.alpha * t_fly + (1.0 - m.alpha) * V, g, T


def gradient_reference(
    problem: Any, P: np.ndarray, R: np.ndarray, T: np.ndarray, y: np.ndarray
) -> tuple[float, np.ndarray]:
    """The flight time t_fly (s) of start -> P -> end and dF/dP (I, 2) (s/m) with numpy, term
    by term as in the module docstring: what `_flight_and_gradient` compiles (tests hold the
    two equal).

    Args:
        problem: the UAV `Problem`.
        P: hover points (I, 2), m.
        R: the points' link rates (I, J), Mbit/s.
        T: the LP's hover times (I,), s.
        y: its coverage duals (J,).

    Returns:
        (t_fly s, dF/dP (I, 2) s/m).
    """
    m = problem.model
    nodes = path_nodes(problem, P)
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
    return t_fly, m.alpha * g_fly + (1.0 - m.alpha) * g_hover


@njit(cache=True, nogil=True)
def _flight_and_gradient(P, start, end, sensors, required, R, T, y, H, decay, v_max, accel,
                         alpha):  # pragma: no cover - compiled
    """`gradient_reference` in one pass (its docstring): (t_fly, g (I, 2))."""
    n = P.shape[0]
    g = np.zeros((n, 2))
    t_fly = 0.0
    cruise = v_max * v_max / accel
    px, py = start[0], start[1]
    ux_prev, uy_prev = 0.0, 0.0
    for k in range(n + 1):
        qx, qy = (P[k, 0], P[k, 1]) if k < n else (end[0], end[1])
        sx, sy = qx - px, qy - py
        d = math.hypot(sx, sy)
        t_fly += leg_time(d, v_max, accel)
        dt = 1.0 / v_max if d > cruise else 1.0 / math.sqrt(accel * max(d, 1e-12))
        ux, uy = (sx / d * dt, sy / d * dt) if d > 0 else (0.0, 0.0)
        if k > 0:  # point k - 1 ends leg k - 1 and starts leg k
            g[k - 1, 0] = alpha * (ux_prev - ux)
            g[k - 1, 1] = alpha * (uy_prev - uy)
        ux_prev, uy_prev = ux, uy
        px, py = qx, qy
    for i in range(n):
        hx, hy = 0.0, 0.0
        for j in range(sensors.shape[0]):
            if required[j] <= 0 or R[i, j] <= 0:
                continue
            dx, dy = P[i, 0] - sensors[j, 0], P[i, 1] - sensors[j, 1]
            slant = math.sqrt(dx * dx + dy * dy + H * H)
            w = y[j] / required[j]
            hx += T[i] * w * decay * dx / slant
            hy += T[i] * w * decay * dy / slant
        g[i, 0] += (1.0 - alpha) * hx
        g[i, 1] += (1.0 - alpha) * hy
    return t_fly, g


def objective_reference(problem: Any, P: np.ndarray) -> float:
    """F(P) alone, the obvious way: the polish's own LP for the hover times (no drop of points;
    in scheduled access `planner_core.model.hoverlp.scheduled_lp`, not raised), the flight
    time leg by leg; what `objective` computes with its gradient.

    Args:
        problem: the UAV `Problem`.
        P: hover points (I, 2), m.

    Returns:
        F, s (an infeasible LP gives its shortfall solution's times, not None; in scheduled
        access it raises).

    Raises:
        RuntimeError: the LP solver fails, or the scheduled LP is infeasible.
    """
    P = np.asarray(P, dtype=float).reshape(-1, 2)
    m = problem.model
    from planner_core.search.polish import _solve_lp

    if getattr(problem, "scheduled", False):  # the scheduled access's LP, not raised
        from planner_core.model.hoverlp import scheduled_lp

        sol = scheduled_lp(m.rates(P), m.required, m.bandwidth, m.t_max)
        if sol is None:
            raise RuntimeError("scheduled hover-time LP failed: infeasible")
        T = sol[0]
    else:
        T, _ = _solve_lp(m.rates(P), m.required, m.t_max, True, "linprog")
    nodes = path_nodes(problem, P)
    legs = zip(nodes[:-1], nodes[1:], strict=True)
    t_fly = sum(float(m.flight_time(np.linalg.norm(b - a))) for a, b in legs)
    return m.alpha * t_fly + (1.0 - m.alpha) * float(T.sum())


def descend(
    problem: Any,
    x: np.ndarray,
    evaluate: Evaluate,
    *,
    trials: int,
    step: float = STEP,
    min_step: float | None = None,
    race: tuple[int, float] | None = None,
    steps: str | None = None,
) -> Descent | None:
    """Descend from plan x (d,) of the UAV problem `problem` for at most `trials` evaluations.

    `evaluate` (X (n, d) -> f, phi) is the caller's counted evaluation; the start itself is not
    re-evaluated (its f is recomputed from the LP). `race` (n, limit): once n evaluations are
    spent the descent stops unless its best f is <= limit (checked once; `_move`'s race).
    Deterministic (no random numbers).

    Args:
        problem: the UAV `Problem`.
        x: the start plan (d,), problem space.
        evaluate: the caller's counted evaluation, X (n, d) -> (f, phi).
        trials: the most evaluations.
        step: the first step, m (the largest point move of the first trial).
        min_step: the descent stops when the step falls below this, m (None: `MIN_STEP`).
        race: (n, limit): once n evaluations are spent the descent stops unless its best f
            is <= limit (checked once; `_move`'s race); None: no race.
        steps: the step rule, `GLOBAL` or `PER_POINT` (module docstring; `step` m is then
            every point's first step); None: `PER_POINT` on a `large_problem`, else `GLOBAL`.

    Returns:
        The `Descent` (x (d,), f s, phi, evaluations, f_start s); None when x is not a
        feasible plan with at least one hover point, one of its points breaks C3 or C5
        (`held_points`), its LP is infeasible, or `trials` < 1.

    Raises:
        ValueError: another `steps`.
    """
    if min_step is None:
        min_step = MIN_STEP
    if steps is None:
        steps = PER_POINT if large_problem(problem) else GLOBAL
    if steps not in STEP_RULES:
        raise ValueError(f"steps: must be one of {', '.join(STEP_RULES)}, got {steps!r}")
    b = problem.breakdown(np.asarray(x, dtype=float))
    P = hover_of(b)[0]
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
    per_point = steps == PER_POINT
    s = np.full(len(P), float(step))  # the per-point steps (m)
    spent = 0
    while spent < trials and (float(s.max()) if per_point else step) >= min_step:
        if race is not None and spent == race[0] and best_f > race[1]:
            break  # out of the race
        if per_point:  # point i moves s_i against its own gradient
            norm = np.hypot(g[:, 0], g[:, 1])
            if float(norm.max()) <= 0.0:
                break
            move = g / np.where(norm > 0.0, norm, 1.0)[:, None] * s[:, None]
            # a step across the bandwidth limit goes along it instead (C3 projection)
            move = project_c3(problem, P, move, box)
            Pn, Rn, verdict = trial_points(problem, P, move, 1.0, 1.0, box)
        else:
            scale = float(np.abs(g).max())
            if scale <= 0.0:
                break
            Pn, Rn, verdict = trial_points(problem, P, g, scale, step, box)
        kept = False
        if verdict == TRIAL_OK:
            nxt = objective(problem, Pn, warm, Rn)
            if nxt is not None:
                xn = problem.encode(Pn, nxt[2])
                fn, phin = evaluate(xn[None, :])
                spent += 1
                fn = float(np.asarray(fn).reshape(-1)[0])
                phin = float(np.asarray(phin).reshape(-1)[0])
                if deb_better(fn, phin, best_f, best_phi):
                    if per_point:  # Rprop: on where the gradient kept its direction
                        turn = (nxt[1] * g).sum(axis=1)
                        s = np.where(turn > 0.0, s * RPROP_UP,
                                     np.where(turn < 0.0, s * RPROP_DOWN, s))
                    P, g = Pn, nxt[1]
                    best_x, best_f, best_phi = xn, fn, phin
                    kept = True
        step = step * GROW if kept else step * SHRINK
        if not kept:
            s = s * SHRINK
    return Descent(best_x, best_f, best_phi, spent, f_start)


