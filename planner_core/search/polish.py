"""Hover-time polish: for fixed hover positions, the least total hover time that meets C4 (an LP).

Given the hover points of a finished plan, the rates R_ij are fixed, so the hover times solve
(by default `hover_lp`: the LP split into its independent blocks, the small ones solved by a
compiled kernel, the rest by HiGHS through highspy; HiGHS through scipy's `linprog` on the whole
LP, the reference; or the same LP stated in cvxpy)
    minimise sum_i T_i   s.t.  sum_i R_ij T_i >= Q_j (all sensors j),  0 <= T_i <= T_max.
C3 depends on positions only and is reported, not changed. Points whose polished time is ~0 are
dropped when the path without them stays collision-free and its flight time does not grow.
Q_j is monotone in every T_i, so the LP is feasible exactly when each sensor alone is served with
every T_i = T_max: an infeasible plan is always explained sensor by sensor.
"""

from __future__ import annotations

import os
import sys
import threading
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numba import njit

from planner_core.model.formulas import L_VIO_TOL
from planner_core.model.geometry import overlap_lengths
from planner_core.model.problem import Problem

__all__ = ["BACKENDS", "PolishResult", "hover_lp", "polish_hover_times", "ZERO_TIME"]

#: A polished hover time at or below this many seconds counts as zero (candidate for dropping).
ZERO_TIME = 1e-3


@dataclass(frozen=True)
class PolishResult:
    """Polished hover points/times, which original points were dropped, and what cannot be met."""

    hover_points: np.ndarray
    hover_times: np.ndarray
    dropped: tuple[int, ...]
    feasible_c4: bool
    unserved: tuple[dict[str, Any], ...] = field(default=())
    c3_violation: float = 0.0
    solver: str = ""

    def describe(self) -> list[str]:
        """One line per sensor that no hover times can serve, saying why."""
        return [u["message"] for u in self.unserved]


def _route_flight_time(problem: Problem, pts: np.ndarray) -> float:
    nodes = np.vstack([problem.start, pts, problem.end])
    d = np.linalg.norm(np.diff(nodes, axis=0), axis=1)
    return float(problem.model.flight_time(d).sum())


def _route_overlap(problem: Problem, pts: np.ndarray) -> float:
    """L_vio of start -> pts -> end (0 when collision-free)."""
    nodes = np.vstack([problem.start, pts, problem.end])
    length = float(overlap_lengths(nodes[:-1], nodes[1:], problem.obstacles).sum())
    return length if length > L_VIO_TOL else 0.0


def _unserved(problem: Problem, R: np.ndarray) -> list[dict[str, Any]]:
    out = []
    best = R.sum(axis=0) * problem.t_max if len(R) else np.zeros(len(problem.required))
    for j, sid in enumerate(problem.map.sensor_ids):
        need = float(problem.required[j])
        if need <= 0 or best[j] >= need:
            continue
        if len(R) == 0 or not np.any(R[:, j] > 0):
            reason = "out of radio range of every hover point"
            msg = f"sensor '{sid}': {reason} (needs {need:g} Mbit, gets 0)"
        else:
            reason = "T_max too small"
            msg = (
                f"sensor '{sid}': {reason}: hovering T_max = {problem.t_max:g} s at every point "
                f"collects {best[j]:.6g} of {need:g} Mbit"
            )
        out.append({"sensor": sid, "reason": reason, "required": need,
                    "max_collectable": float(best[j]), "message": msg})
    return out


#: LP back-ends: "highs" calls HiGHS directly through highspy (`hover_lp`; the planner's
#: default), or through scipy's `linprog` for the infeasible (shortfall) LP; "linprog" always
#: goes through scipy (the reference); "cvxpy" states the same LP in cvxpy (the modelling
#: layer; about a second of import time).
BACKENDS = ("highs", "linprog", "cvxpy")


#: the coverage rows' right-hand side (each sensor's data scaled to 1): a hair above the
#: requirement, so solver tolerance cannot leave a tiny shortfall
_TARGET = 1.0 + 1e-9


def _lp_matrices(
    R: np.ndarray, req: np.ndarray, t_max: float, feasible: bool
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The LP as  min c.z  s.t.  G z <= h,  0 <= z <= ub,  with z = [T (I), s (shortfalls)].

    Feasible: minimise sum T with (R^T T)_j / Q_j >= 1 for every sensor that needs data.
    Infeasible: least relative shortfall s first, then least hover time (weights keep them apart).
    """
    n = R.shape[0]
    need = req > 0
    A = (R[:, need] / req[need]).T  # rows: sensors, scaled so each needs 1 unit
    m = A.shape[0]
    target = np.full(m, _TARGET)
    if feasible or m == 0:
        return np.ones(n), -A, -target, np.full(n, t_max)
    c = np.concatenate([np.full(n, 1.0 / (n * t_max)), np.full(m, 1e3)])
    G = -np.hstack([A, np.eye(m)])
    ub = np.concatenate([np.full(n, t_max), np.full(m, np.inf)])
    return c, G, -target, ub


def _solve_lp(
    R: np.ndarray, req: np.ndarray, t_max: float, feasible: bool, backend: str = "highs"
) -> tuple[np.ndarray, str]:
    """Hover times (I,) solving the LP of `_lp_matrices`, and the solver's name. "highs" on a
    feasible LP takes the fast path (`hover_lp`: the LP by blocks, small ones in a compiled
    kernel, the rest through highspy; ~0.02-0.05 ms on the suite's final plans where scipy's
    `linprog` takes ~1.3 ms); "linprog" is scipy's HiGHS, the reference the fast
    path is tested against and what "highs" uses for the infeasible (shortfall) LP. A
    feasible LP that turns out infeasible at its target (a sensor served exactly at T_max: the
    target is a hair above Q_j) is solved as the shortfall LP instead, which always has a
    solution; the caller's C4 check then sees the hair. Raises ValueError for an unknown
    backend, RuntimeError when the solver itself fails."""
    if feasible and backend == "highs":
        lp = hover_lp(R, req, t_max)
        if lp is not None:
            return lp[0], "blocks + HiGHS (highspy)"
    elif feasible:
        try:
            return _solve_lp_with(R, req, t_max, True, backend)
        except _LPInfeasible:
            pass
    return _solve_lp_with(R, req, t_max, False, backend)


class _LPInfeasible(RuntimeError):
    """The hover-time LP has no solution at its target."""


def _solve_lp_with(
    R: np.ndarray, req: np.ndarray, t_max: float, feasible: bool, backend: str
) -> tuple[np.ndarray, str]:
    """`_solve_lp` on one backend with no fallback; raises `_LPInfeasible` (a RuntimeError)."""
    c, G, h, ub = _lp_matrices(R, req, t_max, feasible)
    if backend in ("highs", "linprog"):
        from scipy.optimize import linprog

        bounds = list(zip(np.zeros_like(ub), np.where(np.isinf(ub), None, ub), strict=True))
        res = linprog(c, A_ub=G if len(h) else None, b_ub=h if len(h) else None,
                      bounds=bounds, method="highs")
        if res.x is None:
            raise _LPInfeasible(f"hover-time LP failed: {res.message}")
        z, solver = res.x, "HiGHS (scipy)"
    elif backend == "cvxpy":
        import cvxpy as cp

        zv = cp.Variable(len(c))
        cons = [zv >= 0, zv[np.isfinite(ub)] <= ub[np.isfinite(ub)]]
        if len(h):
            cons.append(G @ zv <= h)
        prob = cp.Problem(cp.Minimize(c @ zv), cons)
        prob.solve(solver="HIGHS" if "HIGHS" in cp.installed_solvers() else None)
        if zv.value is None:
            raise _LPInfeasible(f"hover-time LP failed: {prob.status}")
        z = np.asarray(zv.value, dtype=float)
        solver = f"cvxpy/{prob.solver_stats.solver_name}" if prob.solver_stats else "cvxpy"
    else:
        raise ValueError(f"backend: unknown '{backend}', choose one of {', '.join(BACKENDS)}")
    return np.clip(z[: R.shape[0]], 0.0, t_max), solver


_HIGHS = threading.local()


def _highs() -> Any:
    """This thread's HiGHS solver (highspy), made quiet. highspy prints a banner to file
    descriptor 1 when a process constructs its first solver, so fd 1 points at the null
    device for that moment (the planner's stdout may be a mission file)."""
    h = getattr(_HIGHS, "solver", None)
    if h is None:
        import highspy

        try:
            if sys.stdout is not None:
                sys.stdout.flush()
            saved = os.dup(1)
        except (OSError, ValueError):  # no stdout (closed fd 1, sys.stdout None): nothing to hide
            h = highspy.Highs()
        else:
            null = os.open(os.devnull, os.O_WRONLY)
            try:
                os.dup2(null, 1)
                h = highspy.Highs()
            finally:
                os.dup2(saved, 1)
                os.close(saved)
                os.close(null)
        h.setOptionValue("output_flag", False)
        _HIGHS.solver = h
    return h


#: blocks of the hover-time LP with at most this many points, and at most `BLOCK_COMBOS` sets
#: of constraints to try as a vertex, are solved by enumerating their vertices (`_lp_blocks`);
#: the others go to HiGHS (with the final stage's second structure, 3 -> 4 -> 5 points took
#: T16's warm plan() from 0.97 to 0.85 to 0.82 s; bench_plan.py)
BLOCK_VERTICES = 5
BLOCK_COMBOS = 5000


def hover_lp(
    R: np.ndarray, req: np.ndarray, t_max: float, warm: dict[Any, Any] | None = None
) -> tuple[np.ndarray, float, np.ndarray] | None:
    """The feasible hover-time LP of `_lp_matrices` with its duals, for sensitivity analysis.

    R (I, J) link rates (Mbit/s) of the hover points to every sensor, req (J,) required data
    Q_j (Mbit), t_max (s). Returns (T (I,) hover times in s, topped up so that C4 holds
    exactly (`_top_up`), V = sum T in s, y (J,) >= 0 the duals of the coverage rows
    (R^T T)_j / Q_j >= 1, zero for sensors that need nothing), or None when the LP is
    infeasible (some sensor not served even at T_max everywhere). By LP sensitivity (e.g.
    Bertsimas & Tsitsiklis, Introduction to Linear Optimization, Sec. 5.1), dV/dR_ij =
    -y_j T_i / Q_j at a non-degenerate optimum: what `planner_core.search.descent` uses.

    The LP separates into blocks, the connected parts of the graph that joins a point to the
    sensors it reaches (R_ij > 0). `_lp_blocks` (compiled) solves a block of one point (on the
    suite's plans most of them) in closed form, T_i = max_j Q_j / R_ij over its sensors with
    dual 1 / A_ji on the first row that attains it, and a block of up to `BLOCK_VERTICES`
    points by enumerating its vertices (at most `BLOCK_COMBOS` sets of constraints); larger
    blocks (and a small block whose optimum would need more than t_max) go together to HiGHS
    through highspy. HiGHS's fixed cost (~0.1 ms a call) is what the blocks save: the descent
    solves this LP once per trial. The fast path
    of the polish's LP (`_solve_lp(..., "linprog")`, one LP through scipy, is its reference;
    tests/test_descent.py holds them equal; `_solve_lp(..., "highs")` calls it for a feasible
    LP). `warm`: a dict the caller keeps for one sequence of related solves (a descent): the
    last optimal basis of each shape of HiGHS's part is kept in it and the next solve starts
    from it. Where the LP has several optima the one returned may depend on that basis, so a
    caller that must be reproducible passes a fresh dict per sequence (None: a cold start,
    the same answer whatever was solved before).
    """
    need = req > 0
    n = R.shape[0]
    y = np.zeros(len(req))
    if not need.any():
        return np.zeros(n), 0.0, y
    # rows: sensors, scaled so each needs 1 unit; cols: points
    A = np.ascontiguousarray((R[:, need] / req[need]).T)
    T = np.zeros(n)
    yn = np.zeros(A.shape[0])
    rest = np.zeros(n, dtype=np.bool_)
    if not _lp_blocks(A, _TARGET, float(t_max), BLOCK_VERTICES, BLOCK_COMBOS, T, yn, rest):
        return None  # a sensor no point reaches, or a lone point that needs more than t_max
    if rest.any():
        rows = (A[:, rest] > 0.0).any(axis=1)
        sol = _highs_lp(A[np.ix_(rows, rest)], _TARGET, t_max, warm)
        if sol is None:
            return None
        T[rest], yn[rows] = sol
    y[need] = yn
    T = _top_up(R, req, np.clip(T, 0.0, t_max), t_max)
    return T, float(T.sum()), y


@njit(cache=True, fastmath=False, nogil=True)
def _solve_small(M, rhs, out):  # pragma: no cover - compiled
    """Gaussian elimination with partial pivoting on a copy of M (k, k); out = M^-1 rhs.
    False when M is singular (a pivot below 1e-12 of M's largest entry)."""
    k = M.shape[0]
    W = M.copy()
    v = rhs.copy()
    big = 0.0
    for i in range(k):
        for j in range(k):
            big = max(big, abs(W[i, j]))
    for col in range(k):
        p = col
        for i in range(col + 1, k):
            if abs(W[i, col]) > abs(W[p, col]):
                p = i
        if abs(W[p, col]) <= 1e-12 * big:
            return False
        if p != col:
            for j in range(k):
                W[col, j], W[p, j] = W[p, j], W[col, j]
            v[col], v[p] = v[p], v[col]
        for i in range(col + 1, k):
            f = W[i, col] / W[col, col]
            for j in range(col, k):
                W[i, j] -= f * W[col, j]
            v[i] -= f * v[col]
    for i in range(k - 1, -1, -1):
        s = v[i]
        for j in range(i + 1, k):
            s -= W[i, j] * out[j]
        out[i] = s / W[i, i]
    return True


@njit(cache=True, fastmath=False, nogil=True)
def _lp_blocks(A, target, t_max, kmax, max_combos, T, y, rest):  # pragma: no cover - compiled
    """The blocks of min sum T s.t. A T >= target, 0 <= T <= t_max (A (rows, I) >= 0): writes
    the hover times T (I,) and row duals y (rows,) of every block of at most `kmax` points and
    marks the points of the others (and of blocks with more than `max_combos` vertices to try)
    in `rest` (I,) for HiGHS. A small block's vertices are
    enumerated: every k of its constraints (its rows, T_i >= 0) taken as equalities, the first
    (in lexicographic order) whose T is feasible and whose multipliers z (N_S^T z = 1, the
    constraints written as >=) are >= 0 (the KKT conditions of an optimal vertex); a block
    with no such vertex within rounding, or whose optimum needs more than t_max, goes to
    `rest`. Returns False when a row has no point or a lone point needs more than t_max."""
    m, n = A.shape
    parent = np.arange(n)
    for j in range(m):  # union-find over the points that share a row
        first = -1
        for i in range(n):
            if A[j, i] > 0.0:
                if first < 0:
                    first = i
                    while parent[first] != first:
                        first = parent[first]
                else:
                    r = i
                    while parent[r] != r:
                        r = parent[r]
                    if r != first:
                        parent[max(r, first)] = min(r, first)
                        first = min(r, first)
        if first < 0:
            return False  # a sensor no point reaches
    for i in range(n):
        r = i
        while parent[r] != r:
            r = parent[r]
        parent[i] = r
    cols = np.empty(n, dtype=np.int64)
    rows = np.empty(m, dtype=np.int64)
    for root in range(n):
        k = 0
        for i in range(n):
            if parent[i] == root:
                cols[k] = i
                k += 1
        if k == 0:
            continue
        nr = 0
        for j in range(m):
            for q in range(k):
                if A[j, cols[q]] > 0.0:
                    rows[nr] = j
                    nr += 1
                    break
        if k == 1:
            i = cols[0]
            best, jb = 0.0, -1
            for q in range(nr):
                t = target / A[rows[q], i]
                if t > best:
                    best, jb = t, rows[q]
            if best > t_max:
                return False
            T[i] = best
            if jb >= 0:
                y[jb] = 1.0 / A[jb, i]
            continue
        c = nr + k  # the block's constraints: its rows, then T_q >= 0
        combos = 1.0
        for q in range(k):  # C(c, k): the vertices to try
            combos = combos * (c - q) / (q + 1)
        if k > kmax or combos > max_combos:
            for q in range(k):
                rest[cols[q]] = True
            continue
        # the largest entry of each of the block's constraints (rows; a bound's is 1) and of
        # each of its points: the tolerances below are relative to them (unit-free)
        cmax = np.ones(c)
        tmax_a = np.zeros(k)
        for q in range(nr):
            m_row = 0.0
            for a in range(k):
                v = A[rows[q], cols[a]]
                m_row = max(m_row, v)
                tmax_a[a] = max(tmax_a[a], v)
            cmax[q] = m_row
        idx = np.arange(k)
        M = np.empty((k, k))
        Mt = np.empty((k, k))
        b = np.empty(k)
        ones = np.ones(k)
        t = np.empty(k)
        z = np.empty(k)
        found = False
        while True:
            for a in range(k):
                s = idx[a]
                for q in range(k):
                    M[a, q] = A[rows[s], cols[q]] if s < nr else (1.0 if s - nr == q else 0.0)
                b[a] = target if s < nr else 0.0
            for a in range(k):
                for q in range(k):
                    Mt[a, q] = M[q, a]
            if _solve_small(M, b, t) and _solve_small(Mt, ones, z):
                ok = True
                for a in range(k):  # multiplier x its constraint's scale; time x data rate
                    if z[a] * cmax[idx[a]] < -1e-9 or t[a] * tmax_a[a] < -1e-9:
                        ok = False
                        break
                if ok:
                    for q in range(nr):
                        s = 0.0
                        scale = target
                        for a in range(k):
                            s += A[rows[q], cols[a]] * t[a]
                            scale += abs(A[rows[q], cols[a]] * t[a])
                        if s < target - 1e-9 * scale:
                            ok = False
                            break
                if ok:
                    found = True
                    break
            # next combination of k out of c, lexicographic
            a = k - 1
            while a >= 0 and idx[a] == c - k + a:
                a -= 1
            if a < 0:
                break
            idx[a] += 1
            for q in range(a + 1, k):
                idx[q] = idx[q - 1] + 1
        tmax_ok = True
        if found:
            for a in range(k):
                if t[a] > t_max:
                    tmax_ok = False
        if not found or not tmax_ok:
            for q in range(k):
                rest[cols[q]] = True
            continue
        for a in range(k):
            T[cols[a]] = max(t[a], 0.0)
            s = idx[a]
            if s < nr:
                y[rows[s]] = max(z[a], 0.0)
    return True


def _highs_lp(
    A: np.ndarray, target: float, t_max: float, warm: dict[Any, Any] | None
) -> tuple[np.ndarray, np.ndarray] | None:
    """min sum T s.t. A T >= target, 0 <= T <= t_max through HiGHS (highspy): (T (cols,), row
    duals (rows,) >= 0), or None when infeasible. A (rows, cols) >= 0; `warm` as `hover_lp`'s
    (keyed by A's shape)."""
    import highspy

    n = A.shape[1]
    nz = A != 0.0
    lp = highspy.HighsLp()
    lp.num_col_, lp.num_row_ = n, A.shape[0]
    lp.col_cost_, lp.col_lower_, lp.col_upper_ = np.ones(n), np.zeros(n), np.full(n, t_max)
    lp.row_lower_ = np.full(A.shape[0], target)
    lp.row_upper_ = np.full(A.shape[0], highspy.kHighsInf)
    lp.a_matrix_.format_ = highspy.MatrixFormat.kRowwise
    lp.a_matrix_.start_ = np.concatenate([[0], np.cumsum(nz.sum(axis=1))]).astype(np.int32)
    lp.a_matrix_.index_ = np.nonzero(nz)[1].astype(np.int32)
    lp.a_matrix_.value_ = A[nz]
    solver = _highs()
    solver.passModel(lp)
    basis = warm.get(A.shape) if warm is not None else None
    if basis is not None:
        solver.setBasis(basis)
    solver.run()
    if solver.getModelStatus() != highspy.HighsModelStatus.kOptimal:
        if warm is not None:
            warm.pop(A.shape, None)
        return None
    if warm is not None:
        warm[A.shape] = solver.getBasis()
    sol = solver.getSolution()
    return (np.clip(np.asarray(sol.col_value, dtype=float), 0.0, t_max),
            np.maximum(np.asarray(sol.row_dual, dtype=float), 0.0))


def _top_up(R: np.ndarray, req: np.ndarray, times: np.ndarray, t_max: float) -> np.ndarray:
    """Scale times up by the worst remaining ratio (tiny) so Q_j >= req_j holds exactly."""
    for _ in range(5):
        Q = R.T @ times
        short = (req > 0) & (Q < req)
        if not short.any():
            break
        ratio = float(np.max(req[short] / np.maximum(Q[short], 1e-300)))
        times = np.minimum(times * min(ratio * (1 + 1e-12), 1.0 + 1e-6) + 1e-12, t_max)
    return times


def polish_hover_times(
    problem: Problem,
    hover_points: np.ndarray,
    hover_times: np.ndarray | None = None,
    *,
    backend: str = "highs",
) -> PolishResult:
    """Solve the hover-time LP for these positions and drop points whose time is ~0 when safe.

    `backend` is "highs" (the default, quick: `hover_lp`, the LP by blocks, small ones in a
    compiled kernel, larger ones through highspy), "linprog" (HiGHS through scipy on the whole
    LP, the reference) or "cvxpy"; same LP (`BACKENDS`).
    """
    pts = np.asarray(hover_points, dtype=float).reshape(-1, 2)
    req = problem.required.astype(float)
    R = problem.rates(pts) if len(pts) else np.zeros((0, len(req)))
    unserved = _unserved(problem, R)
    feasible = not unserved
    solver = ""
    if len(pts):
        times, solver = _solve_lp(R, req, problem.t_max, feasible, backend)
        if feasible:
            times = _top_up(R, req, times, problem.t_max)
    else:
        times = np.zeros(0)
    keep = np.ones(len(pts), dtype=bool)
    if problem.variable_length:
        changed = True
        while changed:
            changed = False
            for i in np.flatnonzero(keep & (times <= ZERO_TIME)):
                trial = keep.copy()
                trial[i] = False
                # a collision-free path must stay so; a colliding one must not get worse
                if _route_overlap(problem, pts[trial]) > _route_overlap(problem, pts[keep]):
                    continue
                if _route_flight_time(problem, pts[trial]) > _route_flight_time(problem, pts[keep]):
                    continue
                keep = trial
                changed = True
                break
        # dropping a ~0 s point may leave a sliver of data uncollected: re-solve on the kept points
        if not keep.all() and keep.any():
            times_k, solver_k = _solve_lp(R[keep], req, problem.t_max, feasible, backend)
            if feasible:
                times_k = _top_up(R[keep], req, times_k, problem.t_max)
            if feasible and np.any(R[keep].T @ times_k < req):
                keep = np.ones(len(pts), dtype=bool)  # the kept points fall short: drop none
            else:
                times, solver = np.zeros(len(pts)), solver_k
                times[keep] = times_k
    c3 = float(np.maximum(R[keep].sum(axis=1) - problem.bandwidth, 0.0).sum())
    return PolishResult(
        hover_points=pts[keep],
        hover_times=times[keep],
        dropped=tuple(int(i) for i in np.flatnonzero(~keep)),
        feasible_c4=feasible,
        unserved=tuple(unserved),
        c3_violation=c3,
        solver=solver,
    )


#: how many of the final population's Deb-best individuals `polish_elite` re-times (issue 14:
#: the DE's Deb-best is often not the best after the LP; 16 LP solves cost ~0.1 s on T16)
ELITE = 16


def polish_elite(
    problem: Problem, X: np.ndarray, f: np.ndarray, phi: np.ndarray, k: int = ELITE
) -> tuple[np.ndarray, list[PolishResult]]:
    """The hover-time LP for the k Deb-best distinct rows of a population.

    X (n, d) problem space with f, phi (n,); returns the polished decision vectors (m, d),
    m <= k, in Deb order of the inputs, and their `PolishResult`s. The caller evaluates them
    (and counts those evaluations) and keeps the best."""
    from planner_core.model.formulas import deb_order

    X = np.asarray(X, dtype=float)
    out, results, seen = [], [], set()
    for i in deb_order(np.asarray(f, dtype=float), np.asarray(phi, dtype=float)):
        key = X[i].tobytes()
        if key in seen:
            continue
        seen.add(key)
        b = problem.breakdown(X[i])
        pol = polish_hover_times(problem, b["hover_points"], b["hover_times"])
        out.append(problem.encode(pol.hover_points, pol.hover_times))
        results.append(pol)
        if len(out) >= k:
            break
    return np.asarray(out, dtype=float).reshape(len(out), X.shape[1]), results
