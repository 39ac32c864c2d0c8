"""One descent trial's points (`planner_core.search.descent`): every hover point moved against
the gradient, the points that break C3 (summed link rate over the bandwidth; none in scheduled
access, where the limit is `ModelParams.c3_limit`, inf) or whose legs cut an obstacle (C5)
slid along the limit by +-45 degrees, and what still breaks either put back.

`trial_points` does it in one compiled call (`_trial_kernel`); `trial_points_reference` is
the same sequence in numpy, step by step, and tests hold the two equal to the bit
(tests/test_scaling_paths.py). `held_points` / `HeldCheck` answer "which points break C3 or
C5" for a whole point set or for one that changes a few points at a time; `held_points`
is also one compiled call (`_held_mask`, its twin `held_points_reference`).

Cost per trial: O(I x sensors in range) link rates and C3 sums (a point's window summed in
order decides C3 unless it lies within `_SUM_SLACK` of the bandwidth, where the pairwise sum
over its J rates does), an (I, J) rate matrix for the objective, and I + 1 legs against the
obstacles (tiled, `planner_core.model.geometry`); with k held points 2 k turns (their rates
and 4 k legs) and at most I rounds putting points back.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numba import njit

from planner_core.model.formulas import (
    L_VIO_TOL,
    _link_rates_2d,
    _link_rates_window,
    numpy_sum,
    slant_rate_grad,
    window_pair_rate,
    window_range,
)
from planner_core.model.geometry import cut_legs, overlap_first

__all__ = [
    "C3_MARGIN",
    "C3_TOLERANCE",
    "PROJECT_SLACK",
    "PROJECT_STEPS",
    "SLIDE_ANGLES",
    "TRIAL_HELD",
    "TRIAL_OK",
    "TRIAL_SAME",
    "HeldCheck",
    "held_points",
    "held_points_reference",
    "path_nodes",
    "project_c3",
    "project_c3_reference",
    "trial_points",
    "trial_points_reference",
]


def path_nodes(problem: Any, P: np.ndarray) -> np.ndarray:
    """start -> P (I, 2) -> end as one (I + 2, 2) array.

    Args:
        problem: its `start` and `end` (2,) m read.
        P: hover points (I, 2), m.

    Returns:
        (I + 2, 2) nodes, m.
    """
    out = np.empty((len(P) + 2, 2))
    out[0] = problem.start
    out[1:-1] = P
    out[-1] = problem.end
    return out


def held_points(problem: Any, P: np.ndarray, R: np.ndarray | None = None) -> np.ndarray:
    """Indices of the hover points P (I, 2) m that break C3 (summed link rate above the
    bandwidth) or end or start a leg that cuts an obstacle by more than `L_VIO_TOL` (C5).
    `R`: the points' link rates (I, J) Mbit/s, when the caller has them. The flags come from
    one compiled call (`_held_mask`); `held_points_reference` is the numpy twin (tests).
    Cost: O(I x sensors in range) rates (unless given) and sums, and I + 1 legs.

    Args:
        problem: the UAV `Problem` (model, obstacles).
        P: hover points (I, 2), m.
        R: their link rates (I, J) Mbit/s (`ModelParams.rates` of P), or None.

    Returns:
        (h,) int indices into P, ascending.
    """
    m = problem.model
    P = _writable(P)
    R = m.rates(P) if R is None else _writable(R)
    win = m.window
    return np.flatnonzero(_held_mask(P, R, m.start, m.end, win.order, win.xs, float(win.half),
                                     math.isfinite(win.half), m.c3_limit,
                                     problem.obstacles.kernel_arrays, L_VIO_TOL))


def held_points_reference(problem: Any, P: np.ndarray, R: np.ndarray | None = None
                          ) -> np.ndarray:
    """`held_points` in numpy, step by step (tests hold the two equal).

    Args:
        problem: the UAV `Problem`.
        P: hover points (I, 2), m.
        R: their link rates (I, J) Mbit/s, or None.

    Returns:
        (h,) int indices into P, ascending.
    """
    m = problem.model
    bad = (m.rates(P) if R is None else R).sum(axis=1) > m.c3_limit
    nodes = path_nodes(problem, P)
    cut = overlap_first(nodes[:-1], nodes[1:], problem.obstacles) > L_VIO_TOL
    bad |= cut[:-1] | cut[1:]  # leg k ends at point k and leg k + 1 starts there
    return np.flatnonzero(bad)


def _writable(a: np.ndarray) -> np.ndarray:
    """a as a C-contiguous, writable float64 array (a itself when it is one): the one array
    type the compiled calls see, so none compiles twice."""
    a = np.ascontiguousarray(a, dtype=float)
    return a if a.flags.writeable else a.copy()


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
        self.rate_bad = m.rates(P).sum(axis=1) > m.c3_limit
        nodes = path_nodes(problem, P)
        self.cut = overlap_first(nodes[:-1], nodes[1:], problem.obstacles) > L_VIO_TOL

    def held(self) -> np.ndarray:
        """Indices of the points that break C3 or end or start a leg that breaks C5.

        Returns:
            (h,) int indices, ascending.
        """
        return np.flatnonzero(self.rate_bad | self.cut[:-1] | self.cut[1:])

    def moved(self, P: np.ndarray, idx: np.ndarray) -> None:
        """Renew the moved points' flags.

        Args:
            P: the points (I, 2) m after the move.
            idx: the indices of the points that moved.
        """
        m = self.problem.model
        idx = np.asarray(idx, dtype=np.int64)
        self.rate_bad[idx] = m.rates(P[idx]).sum(axis=1) > m.c3_limit
        legs = np.unique(np.concatenate([idx, idx + 1]))  # leg k runs node k -> node k + 1
        nodes = path_nodes(self.problem, P)
        self.cut[legs] = overlap_first(nodes[legs], nodes[legs + 1],
                                         self.problem.obstacles) > L_VIO_TOL


#: the C3 projection (`project_c3`) aims a point at this share of the bandwidth below it (at
#: least `C3_MARGIN` below, so that the trial's own C3 test, numpy's pairwise sum within
#: `_SUM_SLACK`, passes it) and stops once it lies within `C3_TOLERANCE` of the bandwidth
C3_TOLERANCE = 1e-4
C3_MARGIN = 1e-9
#: steps of the C3 projection's safeguarded Newton search along the summed rate's gradient
PROJECT_STEPS = 8
#: metres added to a step's length to give the farthest the projection may move its point back
#: (the cap: a point no place within it takes under the limit keeps its move, for the slides)
PROJECT_SLACK = 1.0


def project_c3(problem: Any, P: np.ndarray, move: np.ndarray, box: np.ndarray) -> np.ndarray:
    """The per-point descent's move (I, 2) with each step that would break C3 projected back
    onto the bandwidth limit: a gradient-projection step (Rosen, "The gradient projection
    method for nonlinear programming. Part II: nonlinear constraints", J. SIAM 9(4), 1961)
    for the one constraint of a point alone, its summed link rate S(p) = sum_j R_ij <=
    R_lambda (paper Sec. 3: R_ij = max(R_c - xi sqrt(d_ij^2 + H^2), 0), C3). Point i's trial
    position is q = clip(P_i - move_i) (the convention of `trial_points` with scale and step
    1); where S(q) > R_lambda, q moves along -grad S(q) (u, unit) to q - t u, with t in
    [0, cap], cap = |move_i| + `PROJECT_SLACK` m (the point goes back at most about as far as
    its step took it). t solves S(q - t u) = R_lambda (1 - `C3_MARGIN`) by a safeguarded
    Newton search (at most `PROJECT_STEPS` steps, stopped within `C3_TOLERANCE` of the
    bandwidth): a Newton step from the last t, clipped to the cap while no t under the limit
    is known, else bisection of the bracket [last t over the limit, least t under it] where
    Newton leaves it. Along the line S is concave where its set of links does not change, so
    Newton from t = 0 lands at or past the limit there; links entering or leaving the radio's
    range and the area's edge (the box clip) break that, hence the bracket. The point taken is
    the last one found under the limit (the nearest to it the search saw), and move_i becomes
    P_i - q'. A point with no place under the limit within the cap keeps its move, for
    `trial_points`' slides; its step (the per-point Rprop step) is not changed.

    Why: on a dense clustered field every hover point sits on its bandwidth limit (L06: the
    summed rate at 99-100 % of R_lambda at every point), the LP's gradient pulls it toward
    its sensors, across the limit, and the slides' +-45 degree turns cross it too, so the
    point stays where it is; projected, it moves along the limit (docs/search.md, "C3
    projection"). Scheduled access (no C3: `ModelParams.c3_limit` inf) returns move as is.

    One compiled call (`_project_kernel`); `project_c3_reference` is the same in numpy, and
    tests hold the two equal to the bit.

    Args:
        problem: the UAV `Problem` (its model's sensors, rate model, sensor window, c3_limit).
        P: hover points (I, 2), m.
        move: the moves (I, 2), m: point i's trial position is clip(P_i - move_i).
        box: the area (2,), m.

    Returns:
        (I, 2) moves, m (a new array).

    Cost: per point, its summed rate and gradient over the sensors in its window (O(J) without
    a finite window); per point over the limit, at most `PROJECT_STEPS` more (2-3 on L04 and
    L06, about 3 on the corridors).
    """
    m = problem.model
    if not m.c3_limit < math.inf:
        return np.array(move, dtype=float)
    win = m.window
    return _project_kernel(
        _writable(P), _writable(move), _writable(box), m.sensors, win.order, win.xs,
        float(win.half), m.altitude**2, m.peak_rate, m.decay, math.isfinite(win.half),
        float(m.c3_limit), C3_MARGIN, C3_TOLERANCE, PROJECT_STEPS, PROJECT_SLACK,
    )  # fmt: skip


def project_c3_reference(problem: Any, P: np.ndarray, move: np.ndarray,
                         box: np.ndarray) -> np.ndarray:
    """`project_c3` the readable way (tests hold the two equal to the bit): each point's sum
    and gradient from numpy arrays of its window's sensors (summed in the window's order, as
    the kernel sums them), one point at a time.

    Args:
        problem, P, move, box: as `project_c3`'s.

    Returns:
        (I, 2) moves, m.
    """
    m = problem.model
    out = np.array(move, dtype=float)
    lim = m.c3_limit
    if not lim < math.inf:
        return out
    P = np.asarray(P, dtype=float)
    box = np.asarray(box, dtype=float)
    win = m.window
    S = np.asarray(m.sensors, dtype=float)
    h2 = m.altitude**2

    def sum_grad(x: float, y: float) -> tuple[float, float, float]:
        if math.isfinite(win.half):
            lo, hi = window_range(win.xs, float(win.half), x)
            idx = np.asarray(win.order)[lo:hi]
        else:
            idx = np.arange(len(S))
        dx, dy = x - S[idx, 0], y - S[idx, 1]
        near = np.abs(dy) < win.half if math.isfinite(win.half) else np.ones(len(idx), bool)
        s = gx = gy = 0.0
        for q in np.flatnonzero(near):  # in the window's order, one term at a time
            rate, dgx, dgy = slant_rate_grad(float(dx[q]), float(dy[q]), h2, m.peak_rate,
                                             m.decay)
            if rate > 0.0:
                s += rate
                gx += dgx
                gy += dgy
        return s, gx, gy

    for i in range(len(P)):
        qx = float(np.clip(P[i, 0] - out[i, 0], 0.0, box[0]))
        qy = float(np.clip(P[i, 1] - out[i, 1], 0.0, box[1]))
        if not (math.isfinite(qx) and math.isfinite(qy)):
            continue
        s, gx, gy = sum_grad(qx, qy)
        norm = math.sqrt(gx * gx + gy * gy)  # not hypot: numba's and CPython's differ
        if not (s > lim and norm > 0.0 and math.isfinite(norm)):
            continue
        ux, uy = gx / norm, gy / norm
        target = lim * (1.0 - C3_MARGIN)
        cap = math.sqrt(out[i, 0] * out[i, 0] + out[i, 1] * out[i, 1]) + PROJECT_SLACK
        lo, hi, t, slope, found = 0.0, math.inf, 0.0, norm, None
        for _ in range(PROJECT_STEPS):
            nxt = t + (s - target) / slope if slope > 0.0 else math.nan
            if hi == math.inf:  # no place under the limit yet: Newton, at most to the cap
                t = min(nxt, cap) if nxt > lo else cap
            else:  # a bracket: Newton inside it, else its midpoint
                t = nxt if lo < nxt < hi else 0.5 * (lo + hi)
            x = float(np.clip(qx - ux * t, 0.0, box[0]))
            y = float(np.clip(qy - uy * t, 0.0, box[1]))
            s, gx, gy = sum_grad(x, y)
            slope = gx * ux + gy * uy
            if s <= target:
                hi, found = t, (x, y)
                if target - s <= C3_TOLERANCE * lim:
                    break
            elif t >= cap:
                break  # over the limit at the cap: no place within it
            else:
                lo = t
        if found is not None:
            out[i, 0], out[i, 1] = P[i, 0] - found[0], P[i, 1] - found[1]
    return out


@njit(cache=True, nogil=True)
def _sum_grad(x, y, sensors, order, xs, half, h2, peak, decay, windowed):  # pragma: no cover
    """The summed link rate S (Mbit/s) of the point (x, y) and its gradient (Mbit/s per m),
    over the sensors of its window in the window's order (all of them in index order without
    one), as `project_c3_reference` sums them. O(sensors in the window)."""
    if windowed:
        lo, hi = window_range(xs, half, x)
    else:
        lo, hi = 0, sensors.shape[0]
    s, gx, gy = 0.0, 0.0, 0.0
    for q in range(lo, hi):
        j = order[q] if windowed else q
        dx = x - sensors[j, 0]
        dy = y - sensors[j, 1]
        if windowed and not abs(dy) < half:
            continue
        rate, dgx, dgy = slant_rate_grad(dx, dy, h2, peak, decay)
        if rate > 0.0:
            s += rate
            gx += dgx
            gy += dgy
    return s, gx, gy


@njit(cache=True, nogil=True)
def _project_kernel(P, move, box, sensors, order, xs, half, h2, peak, decay, windowed, lim,
                    margin, tolerance, steps, slack):  # pragma: no cover - compiled
    """`project_c3` (its docstring): `project_c3_reference`'s loop with the same arithmetic."""
    out = move.copy()
    target = lim * (1.0 - margin)
    for i in range(P.shape[0]):
        qx = _clip1(P[i, 0] - out[i, 0], 0.0, box[0])
        qy = _clip1(P[i, 1] - out[i, 1], 0.0, box[1])
        if not (math.isfinite(qx) and math.isfinite(qy)):
            continue
        s, gx, gy = _sum_grad(qx, qy, sensors, order, xs, half, h2, peak, decay, windowed)
        norm = math.sqrt(gx * gx + gy * gy)  # not hypot: numba's and CPython's differ
        if not (s > lim and norm > 0.0 and math.isfinite(norm)):
            continue
        ux, uy = gx / norm, gy / norm
        cap = math.sqrt(out[i, 0] * out[i, 0] + out[i, 1] * out[i, 1]) + slack
        lo, hi, t, slope = 0.0, math.inf, 0.0, norm
        found = False
        fx, fy = 0.0, 0.0
        for _ in range(steps):
            nxt = t + (s - target) / slope if slope > 0.0 else math.nan
            if hi == math.inf:
                t = min(nxt, cap) if nxt > lo else cap
            else:
                t = nxt if lo < nxt < hi else 0.5 * (lo + hi)
            x = _clip1(qx - ux * t, 0.0, box[0])
            y = _clip1(qy - uy * t, 0.0, box[1])
            s, gx, gy = _sum_grad(x, y, sensors, order, xs, half, h2, peak, decay, windowed)
            slope = gx * ux + gy * uy
            if s <= target:
                hi, found, fx, fy = t, True, x, y
                if target - s <= tolerance * lim:
                    break
            elif t >= cap:
                break
            else:
                lo = t
        if found:
            out[i, 0], out[i, 1] = P[i, 0] - fx, P[i, 1] - fy
    return out


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
    ahead = path_nodes(problem, Pn)  # every point at its step
    Pn = Pn.copy()
    Pn[held] = P[held]
    back = path_nodes(problem, Pn)  # the held points put back
    cand = np.clip(P[held][:, None, :] + np.einsum("aij,kj->kai", _SLIDE, move[held]), 0.0, box)
    c = cand.reshape(-1, 2)
    prev, nxt = np.repeat(back[held], a, axis=0), np.repeat(ahead[held + 2], a, axis=0)
    cut = overlap_first(np.vstack([prev, c]), np.vstack([c, nxt]), problem.obstacles) > L_VIO_TOL
    bad = (cut[: k * a] | cut[k * a:] | (m.rates(c).sum(axis=1) > m.c3_limit)).reshape(k, a)
    first = np.argmax(~bad, axis=1)
    ok = ~bad[np.arange(k), first]
    Pn[held[ok]] = cand[np.arange(k)[ok], first[ok]]
    return Pn


#: `trial_points`' verdicts: evaluate the trial; a point still breaks C3 or C5 (no
#: evaluation); the trial points equal the current ones (no evaluation)
TRIAL_OK, TRIAL_HELD, TRIAL_SAME = 0, 1, 2


def trial_points_reference(
    problem: Any, P: np.ndarray, g: np.ndarray, scale: float, step: float, box: np.ndarray
) -> tuple[np.ndarray, np.ndarray | None, int]:
    """One trial's points, the readable way (what `trial_points` compiles; tests hold the two
    equal): every point P (I, 2) m moved by move = -g / scale * step (g (I, 2) the gradient,
    scale its largest |entry|, step m) and clipped to the area `box` (2,) m; when some point
    then breaks C3 or C5 (`held_points`), the held points slide (`_slide`) and whatever still
    breaks C3 or C5 is put back at P until nothing does (at most I rounds, `HeldCheck`).
    Returns (Pn (I, 2), Pn's link rates (I, J) or None where they were not computed, verdict
    `TRIAL_OK`, `TRIAL_HELD` or `TRIAL_SAME`). Cost: O(I J) rates and I + 1 legs, plus, with
    k held points, 2 k turns (rates and 4 k legs) and a few rounds of the held ones.

    Args:
        problem: the UAV `Problem`.
        P: hover points (I, 2), m.
        g: the gradient (I, 2), s/m.
        scale: its largest |entry| (or 1.0 with a move already scaled).
        step: the step, m.
        box: the area (2,), m.

    Returns:
        (Pn (I, 2) m, its link rates (I, J) Mbit/s or None, verdict).
    """
    move = -g / scale * step
    Pn = np.clip(P + move, 0.0, box)
    Rn = problem.model.rates(Pn)
    held = held_points_reference(problem, Pn, Rn)
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
    if len(held):
        return Pn, Rn, TRIAL_HELD
    return Pn, Rn, TRIAL_SAME if np.array_equal(Pn, P) else TRIAL_OK


def trial_points(
    problem: Any, P: np.ndarray, g: np.ndarray, scale: float, step: float, box: np.ndarray
) -> tuple[np.ndarray, np.ndarray, int]:
    """`trial_points_reference` in one compiled call (`_trial_kernel`): the same points, flags
    and verdict, to the bit (the same operations in the same order, the same batches of legs
    for the obstacle kernel, numpy's pairwise sum for the summed rates; tests), and Pn's link
    rates (I, J) Mbit/s (for `objective`). Cost as the reference's in arithmetic, without its
    ~40 numpy and wrapper calls (~0.2 ms) per trial.

    Args:
        problem, P, g, scale, step, box: as `trial_points_reference`'s.

    Returns:
        (Pn (I, 2) m, rates (I, J) Mbit/s, verdict). The rates are Pn's for `TRIAL_OK` and
        where no point was held; after a slide (`TRIAL_HELD`, or `TRIAL_SAME` once every
        point went back) they are those of the unslid step's points, not Pn's.
    """
    m = problem.model
    win = m.window
    return _trial_kernel(
        _writable(P), _writable(g), float(scale), float(step), _writable(box), m.start, m.end,
        _SLIDE, m.sensors, win.order, win.xs, float(win.half), m.altitude**2, m.peak_rate,
        m.decay, math.isfinite(win.half), m.c3_limit, problem.obstacles.kernel_arrays,
        L_VIO_TOL,
    )  # fmt: skip


@njit(cache=True, nogil=True)
def _clip1(x, lo, hi):  # pragma: no cover - compiled
    """One float64 of ``np.clip(X, lo, box)`` for X (n, 2) or (k, 2, 2) and box (2,), as
    numpy's loop for that broadcast computes it: NaN stays, then x > lo ? x : lo, then
    x < hi ? x : hi (so -0.0 becomes lo = 0.0; tests). O(1)."""
    if not math.isnan(x):
        x = x if x > lo else lo
    if not math.isnan(x):
        x = x if x < hi else hi
    return x


@njit(cache=True, nogil=True)
def _rates_k(pts, sensors, order, xs, half, h2, peak, decay, windowed):  # pragma: no cover
    """`ModelParams.rates` of points (n, 2): the windowed kernel where the cut is finite."""
    if windowed:
        return _link_rates_window(pts, sensors, order, xs, half, h2, peak, decay)
    return _link_rates_2d(pts, sensors, h2, peak, decay)


@njit(cache=True, nogil=True)
def _over_bw(R, bandwidth):  # pragma: no cover - compiled
    """Per row of R (n, J): numpy's ``R.sum(axis=1) > bandwidth`` (its pairwise sum)."""
    n, J = R.shape
    out = np.empty(n, dtype=np.bool_)
    for i in range(n):
        out[i] = numpy_sum(R[i], 0, J) > bandwidth
    return out


#: the relative distance from the bandwidth beyond which a row's sum in any order decides C3
#: as numpy's pairwise sum does: two float64 sums of J >= 1 non-negative terms differ by at
#: most 2 (J - 1) u of the sum (u = 2^-53; Higham, Accuracy and Stability, 2002, Sec. 4.2),
#: taken here with a factor 4 to spare
_SUM_SLACK = 8.0 * 2.0**-53


@njit(cache=True, nogil=True)
def _decided(s, J, bandwidth):  # pragma: no cover - compiled
    """0 / 1: the flag ``sum > bandwidth`` that a row whose sum in some order is s (>= 0)
    takes whatever the order; -1 where s lies too near the bandwidth to tell (`_SUM_SLACK`).
    No sum is above an infinite or NaN bandwidth (scheduled access: `ModelParams.c3_limit`
    inf), so those decide 0 at once."""
    if not bandwidth < math.inf:
        return 0
    if abs(s - bandwidth) > _SUM_SLACK * J * max(s, abs(bandwidth)):
        return 1 if s > bandwidth else 0
    return -1


@njit(cache=True, nogil=True)
def _over_bw_window(R, P, order, xs, half, windowed, bandwidth):  # pragma: no cover - compiled
    """`_over_bw` of the rates R (n, J) of the points P (n, 2), reading only the columns of each
    point's sensor window (`formulas.window_range`; every rate outside it is 0, as both rate
    kernels write it): the window's sum in order decides, unless it lies within
    `_SUM_SLACK` of the bandwidth, where the row's pairwise sum does (the same flags; tests).
    O(n x sensors in the window) where `_over_bw` reads all n J rates."""
    n, J = R.shape
    if not windowed:
        return _over_bw(R, bandwidth)
    out = np.empty(n, dtype=np.bool_)
    for i in range(n):
        px = P[i, 0]
        if not (math.isfinite(px) and math.isfinite(P[i, 1])):
            out[i] = numpy_sum(R[i], 0, J) > bandwidth
            continue
        lo, hi = window_range(xs, half, px)
        s = 0.0
        for q in range(lo, hi):
            s += R[i, order[q]]
        d = _decided(s, J, bandwidth)
        out[i] = numpy_sum(R[i], 0, J) > bandwidth if d < 0 else d == 1
    return out


@njit(cache=True, nogil=True)
def _points_over_bw(pts, sensors, order, xs, half, h2, peak, decay, windowed,
                    bandwidth):  # pragma: no cover - compiled
    """``_over_bw(_rates_k(pts, ...), bandwidth)`` without the (n, J) rates: each point's
    window rates summed as they are computed (`_link_rates_window`'s arithmetic) decide as in
    `_over_bw_window`; a point near the bandwidth, off the map's numbers or without a window
    gets its full row and the pairwise sum (the same flags; tests). O(n x sensors in the
    window)."""
    n, J = pts.shape[0], sensors.shape[0]
    out = np.empty(n, dtype=np.bool_)
    for i in range(n):
        px, py = pts[i, 0], pts[i, 1]
        d = -1
        if windowed and math.isfinite(px) and math.isfinite(py):
            lo, hi = window_range(xs, half, px)
            s = 0.0
            for q in range(lo, hi):
                j = order[q]
                s += window_pair_rate(px, py, sensors[j, 0], sensors[j, 1], half, h2, peak,
                                      decay)
            d = _decided(s, J, bandwidth)
        if d < 0:
            row = _rates_k(pts[i:i + 1], sensors, order, xs, half, h2, peak, decay, windowed)
            out[i] = numpy_sum(row[0], 0, J) > bandwidth
        else:
            out[i] = d == 1
    return out


@njit(cache=True, nogil=True)
def _held_mask(P, R, start, end, order, xs, half, windowed, bandwidth, obst,
               limit):  # pragma: no cover - compiled
    """`held_points_reference` as a mask (I,): points P (I, 2) whose rates R (I, J) sum
    (numpy's pairwise sum, decided as `_over_bw_window` does) above `bandwidth`, or that end
    or start a leg cut by more than `limit` (`cut_legs` on the I + 1 legs in path order, as
    `overlap_first` sees them)."""
    bad = _over_bw_window(R, P, order, xs, half, windowed, bandwidth)
    a, b = _path_legs(P, start, end)
    cut = cut_legs(a, b, obst, limit)
    for i in range(P.shape[0]):
        bad[i] = bad[i] | cut[i] | cut[i + 1]
    return bad


@njit(cache=True, nogil=True)
def _same_points(A, B):  # pragma: no cover - compiled
    """``np.array_equal(A, B)`` for two (n, 2) point arrays of one shape. O(n)."""
    for i in range(A.shape[0]):  # noqa: SIM110 - a compiled loop, not a generator
        if A[i, 0] != B[i, 0] or A[i, 1] != B[i, 1]:
            return False
    return True


@njit(cache=True, nogil=True)
def _path_legs(P, start, end):  # pragma: no cover - compiled
    """The legs start -> P (I, 2) -> end as two (I + 1, 2) arrays of leg starts and ends."""
    n = P.shape[0]
    a = np.empty((n + 1, 2))
    b = np.empty((n + 1, 2))
    a[0, 0], a[0, 1] = start[0], start[1]
    for i in range(n):
        a[i + 1, 0], a[i + 1, 1] = P[i, 0], P[i, 1]
        b[i, 0], b[i, 1] = P[i, 0], P[i, 1]
    b[n, 0], b[n, 1] = end[0], end[1]
    return a, b


@njit(cache=True, nogil=True)
def _renew_flags(Pn, held, k, rate_bad, cut, start, end, sensors, order, xs, half, h2, peak,
                 decay, windowed, bandwidth, obst, limit):  # pragma: no cover - compiled
    """`HeldCheck.moved` in the kernel: the C3 flags `rate_bad` (n,) of the points held[:k] of
    Pn (n, 2) and the C5 flags `cut` (n + 1,) of the legs they end or start, renewed in place
    (the legs in ascending order, once each, in one batch). O(k x sensors in range + 2k legs)."""
    n = Pn.shape[0]
    moved = np.empty((k, 2))
    for q in range(k):
        moved[q, 0], moved[q, 1] = Pn[held[q], 0], Pn[held[q], 1]
    fl = _points_over_bw(moved, sensors, order, xs, half, h2, peak, decay, windowed, bandwidth)
    for q in range(k):
        rate_bad[held[q]] = fl[q]
    leg = np.zeros(n + 1, dtype=np.bool_)  # np.unique(held, held + 1): sorted, once each
    for q in range(k):
        leg[held[q]] = True
        leg[held[q] + 1] = True
    legs = np.flatnonzero(leg)
    nl = legs.shape[0]
    a = np.empty((nl, 2))
    b = np.empty((nl, 2))
    for q in range(nl):
        j = legs[q]  # leg j runs node j -> node j + 1 (node 0 the start, n + 1 the end)
        for d in range(2):
            a[q, d] = start[d] if j == 0 else Pn[j - 1, d]
            b[q, d] = end[d] if j == n else Pn[j, d]
    cl = cut_legs(a, b, obst, limit)
    for q in range(nl):
        cut[legs[q]] = cl[q]


@njit(cache=True, nogil=True)
def _trial_kernel(P, g, scale, step, box, start, end, slide, sensors, order, xs, half, h2, peak,
                  decay, windowed, bandwidth, obst, limit):  # pragma: no cover - compiled
    """`trial_points` (its docstring): `trial_points_reference` step by step, each numpy call
    as a loop with the same arithmetic, each rate matrix and obstacle batch as the reference
    forms it (`held_points`, `_slide`, `HeldCheck`)."""
    n = P.shape[0]
    move = np.empty((n, 2))
    Pn = np.empty((n, 2))
    for i in range(n):
        for d in range(2):
            mv = -g[i, d] / scale * step
            move[i, d] = mv
            Pn[i, d] = _clip1(P[i, d] + mv, 0.0, box[d])
    R = _rates_k(Pn, sensors, order, xs, half, h2, peak, decay, windowed)
    bad = _held_mask(Pn, R, start, end, order, xs, half, windowed, bandwidth, obst, limit)
    k = 0
    for i in range(n):
        k += bad[i]
    if k == 0:
        return Pn, R, 2 if _same_points(Pn, P) else 0
    # `_slide`: each held point's turned steps, checked against its previous node (held points
    # back at P) and its next node (at its step), in one batch of legs
    held = np.flatnonzero(bad)
    na = slide.shape[0]
    back = Pn.copy()
    for q in range(k):
        back[held[q], 0], back[held[q], 1] = P[held[q], 0], P[held[q], 1]
    ka = k * na
    cand = np.empty((ka, 2))
    la = np.empty((2 * ka, 2))
    lb = np.empty((2 * ka, 2))
    for q in range(k):
        h = held[q]
        for t in range(na):
            r = q * na + t
            for d in range(2):
                e = slide[t, d, 0] * move[h, 0] + slide[t, d, 1] * move[h, 1]
                cand[r, d] = _clip1(P[h, d] + e, 0.0, box[d])
                la[r, d] = start[d] if h == 0 else back[h - 1, d]
                lb[ka + r, d] = end[d] if h + 1 == n else Pn[h + 1, d]
                la[ka + r, d] = cand[r, d]
                lb[r, d] = cand[r, d]
    cutc = cut_legs(la, lb, obst, limit)
    badc = _points_over_bw(cand, sensors, order, xs, half, h2, peak, decay, windowed, bandwidth)
    for q in range(k):
        for t in range(na):
            r = q * na + t
            if not (cutc[r] | cutc[ka + r] | badc[r]):
                back[held[q], 0], back[held[q], 1] = cand[r, 0], cand[r, 1]
                break
    # `HeldCheck`: put back what still breaks C3 or C5, renewing the moved points' flags. Its
    # first flags: a point that was not held is where it was checked above and kept C3, and a
    # leg between two such points (or one and the start or end) is the leg checked above and
    # was not cut (else its points were held), so only the held points and their legs are
    # checked again (each flag is the point's or the leg's alone: the same flags)
    Pn = back
    rate_bad = np.zeros(n, dtype=np.bool_)
    cut = np.zeros(n + 1, dtype=np.bool_)
    _renew_flags(Pn, held, k, rate_bad, cut, start, end, sensors, order, xs, half, h2, peak,
                 decay, windowed, bandwidth, obst, limit)
    still = True
    for _ in range(n):
        k = 0
        for i in range(n):
            bad[i] = rate_bad[i] | cut[i] | cut[i + 1]
            k += bad[i]
        if k == 0:
            still = False
            break
        held = np.flatnonzero(bad)
        for q in range(k):
            Pn[held[q], 0], Pn[held[q], 1] = P[held[q], 0], P[held[q], 1]
        _renew_flags(Pn, held, k, rate_bad, cut, start, end, sensors, order, xs, half, h2,
                     peak, decay, windowed, bandwidth, obst, limit)
    if still:
        return Pn, R, 1
    if _same_points(Pn, P):
        return Pn, R, 2
    return Pn, _rates_k(Pn, sensors, order, xs, half, h2, peak, decay, windowed), 0
