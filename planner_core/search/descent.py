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
instead (`_slide`: it slides along the obstacle, where the optimum often lies, with a leg
tangent to it), or, where neither clears, is held in place for that trial; the trial is then
evaluated (one evaluation of the caller's counted `evaluate`) and kept when it is Deb-better
than the current plan. `step` grows 1.5x after a kept trial and halves after a rejected one (a
backtracking line search); the descent stops at `min_step` or after `trials` evaluations. Every
kept plan is feasible and its f is what the evaluator says, so the result is never worse than
the start.

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

from planner_core.model.formulas import L_VIO_TOL, deb_better, leg_time
from planner_core.model.geometry import overlap_first
from planner_core.search.polish import hover_lp

__all__ = [
    "Descent",
    "Evaluate",
    "SLIDE_ANGLES",
    "descend",
    "HeldCheck",
    "held_points",
    "hover_of",
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
    """Hover points (I, 2) m and times (I,) s of a `Problem.breakdown` dict."""
    return (np.asarray(b["hover_points"], dtype=float).reshape(-1, 2),
            np.asarray(b["hover_times"], dtype=float))


def _nodes(problem: Any, P: np.ndarray) -> np.ndarray:
    """start -> P (I, 2) -> end as one (I + 2, 2) array."""
    out = np.empty((len(P) + 2, 2))
    out[0] = problem.start
    out[1:-1] = P
    out[-1] = problem.end
    return out


def objective(
    problem: Any, P: np.ndarray, warm: dict[Any, Any] | None = None,
    R: np.ndarray | None = None,
) -> tuple[float, np.ndarray, np.ndarray] | None:
    """F(P) (s), its gradient dF/dP (I, 2) (s/m) and the LP hover times T (I,) (s) for hover
    points P (I, 2) in metres; None when no hover times serve every sensor (the LP is
    infeasible). `warm`: the LP's warm-start store (`polish.hover_lp`). Module docstring for
    the formulas. `R`: the points' link rates (I, J), when the caller has them."""
    P = np.asarray(P, dtype=float).reshape(-1, 2)
    m = problem.model
    if R is None:
        R = m.rates(P)
    lp = hover_lp(R, m.required, m.t_max, warm)
    if lp is None:
        return None
    T, V, y = lp
    t_fly, g = _flight_and_gradient(P, problem.start, problem.end, m.sensors, m.required, R,
                                    T, y, m.altitude, m.decay, m.v_max, m.accel, m.alpha)
    return m.alpha * t_fly + (1.0 - m.alpha) * V, g, T


def gradient_reference(
    problem: Any, P: np.ndarray, R: np.ndarray, T: np.ndarray, y: np.ndarray
) -> tuple[float, np.ndarray]:
    """The flight time t_fly (s) of start -> P -> end and dF/dP (I, 2) (s/m) with numpy, term
    by term as in the module docstring: what `_flight_and_gradient` compiles (tests hold the
    two equal). R (I, J) the points' link rates, T (I,) the LP's hover times, y (J,) its
    coverage duals."""
    m = problem.model
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
    """F(P) alone, the obvious way: the polish's own LP for the hover times (no drop of points),
    the flight time leg by leg; what `objective` computes with its gradient."""
    P = np.asarray(P, dtype=float).reshape(-1, 2)
    m = problem.model
    from planner_core.search.polish import _solve_lp

    T, _ = _solve_lp(m.rates(P), m.required, m.t_max, True, "linprog")
    nodes = _nodes(problem, P)
    legs = zip(nodes[:-1], nodes[1:], strict=True)
    t_fly = sum(float(m.flight_time(np.linalg.norm(b - a))) for a, b in legs)
    return m.alpha * t_fly + (1.0 - m.alpha) * float(T.sum())


def held_points(problem: Any, P: np.ndarray, R: np.ndarray | None = None) -> np.ndarray:
    """Indices of the hover points P (I, 2) that break C3 (summed link rate above the
    bandwidth) or end or start a leg that cuts an obstacle by more than `L_VIO_TOL` (C5).
    `R`: the points' link rates (I, J), when the caller has them."""
    m = problem.model
    bad = (m.rates(P) if R is None else R).sum(axis=1) > m.bandwidth
    nodes = _nodes(problem, P)
    cut = overlap_first(nodes[:-1], nodes[1:], problem.obstacles) > L_VIO_TOL
    bad |= cut[:-1] | cut[1:]  # leg k ends at point k and leg k + 1 starts there
    return np.flatnonzero(bad)


class HeldCheck:
    """`held_points` of a point set that changes a few points at a time: the C3 flag of each
    point and the C5 flag of each leg are kept, and `moved` recomputes only the moved points'
    rates and the legs they end or start. Each flag is computed as `held_points` computes it
    (a point's rates and a leg's overlap do not depend on the others), so `held` equals
    `held_points` on the current points (tests). Cost per `moved`: O(k J) rates and 2k legs
    for k moved points instead of O(I J) and I + 1 legs."""

    def __init__(self, problem: Any, P: np.ndarray) -> None:
        """P (I, 2): the hover points now (m)."""
        self.problem = problem
        m = problem.model
        self.rate_bad = m.rates(P).sum(axis=1) > m.bandwidth
        nodes = _nodes(problem, P)
        self.cut = overlap_first(nodes[:-1], nodes[1:], problem.obstacles) > L_VIO_TOL

    def held(self) -> np.ndarray:
        """Indices of the points that break C3 or end or start a leg that breaks C5."""
        return np.flatnonzero(self.rate_bad | self.cut[:-1] | self.cut[1:])

    def moved(self, P: np.ndarray, idx: np.ndarray) -> None:
        """The points P (I, 2) after the points idx (indices) moved: their flags renewed."""
        m = self.problem.model
        idx = np.asarray(idx, dtype=np.int64)
        self.rate_bad[idx] = m.rates(P[idx]).sum(axis=1) > m.bandwidth
        legs = np.unique(np.concatenate([idx, idx + 1]))  # leg k runs node k -> node k + 1
        nodes = _nodes(self.problem, P)
        self.cut[legs] = overlap_first(nodes[legs], nodes[legs + 1],
                                         self.problem.obstacles) > L_VIO_TOL


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
    cut = overlap_first(np.vstack([prev, c]), np.vstack([c, nxt]), problem.obstacles) > L_VIO_TOL
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
    spent = 0
    while spent < trials and step >= min_step:
        if race is not None and spent == race[0] and best_f > race[1]:
            break  # out of the race
        scale = float(np.abs(g).max())
        if scale <= 0.0:
            break
        move = -g / scale * step
        Pn = np.clip(P + move, 0.0, box)
        Rn = problem.model.rates(Pn)
        held = held_points(problem, Pn, Rn)
        if len(held):
            Rn = None  # the held points move again
            Pn = _slide(problem, P, Pn, move, held, box)
            check = HeldCheck(problem, Pn)
            for _ in range(len(P)):  # what still breaks C3 or C5 stays where it was
                held = check.held()
                if not len(held):
                    break
                Pn[held] = P[held]
                check.moved(Pn, held)
        kept = False
        if not len(held) and not np.array_equal(Pn, P):
            nxt = objective(problem, Pn, warm, Rn)
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


