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

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from planner_core.model.formulas import L_VIO_TOL
from planner_core.model.geometry import overlap_lengths
from planner_core.model.hoverlp import (  # noqa: F401 - re-exported: the LP's home is the model
    BLOCK_COMBOS,
    BLOCK_VERTICES,
    _highs,
    _highs_lp,
    _lp_blocks,
    _solve_small,
)
from planner_core.model.hoverlp import TARGET as _TARGET
from planner_core.model.hoverlp import hover_lp as _hover_lp
from planner_core.model.hoverlp import top_up as _top_up
from planner_core.model.problem import Problem

__all__ = ["BACKENDS", "PolishResult", "hover_lp", "polish_hover_times", "scheduled_hover_lp",
           "ZERO_TIME"]

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
        """One line per sensor that no hover times can serve, saying why.

        Returns:
            The `unserved` entries' messages, in sensor order.
        """
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


def _dropped_overlap(problem: Problem, pts: np.ndarray, keep: np.ndarray, i: int,
                     kept_overlap: float) -> float:
    """`_route_overlap` of the kept points pts[keep] without point i, given the kept route's
    own (`kept_overlap`). Where that is 0 and the kept points are finite every kept leg's
    overlap is 0 (each obstacle's is 0 or above 2 tol > `L_VIO_TOL`,
    `geometry.overlap_first`), so the sum over the route without i is the new leg's alone, to
    the bit: one leg tested instead of the route. O(obstacles) then, else O(I x obstacles)."""
    if kept_overlap != 0.0 or not np.isfinite(pts[keep]).all():  # NaN legs compare false
        trial = keep.copy()
        trial[i] = False
        return _route_overlap(problem, pts[trial])
    nodes = np.vstack([problem.start, pts[keep], problem.end])
    at = int(np.count_nonzero(keep[:i])) + 1  # i's node among the kept route's
    length = float(overlap_lengths(nodes[at - 1:at], nodes[at + 1:at + 2],
                                   problem.obstacles).sum())
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
    `linprog` takes ~1.3 ms) and the infeasible (shortfall) LP whole through highspy (no
    scipy.optimize import: 0.27 s the first time, once per large plan); "linprog" is scipy's
    HiGHS, the reference both are tested against. A
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
    if backend == "highs":  # through highspy, as the fast path: no scipy.optimize to import
        from scipy.sparse import csr_matrix

        from planner_core.model.hoverlp import _highs_general

        out = _highs_general(c, np.zeros_like(ub), ub, csr_matrix(G), np.full(len(h), -np.inf),
                             h)
        if out is None:
            raise _LPInfeasible("hover-time LP failed: HiGHS found no optimum")
        z, solver = out[0], "HiGHS (highspy)"
    elif backend == "linprog":
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


def hover_lp(
    R: np.ndarray, req: np.ndarray, t_max: float, warm: dict[Any, Any] | None = None
) -> tuple[np.ndarray, float, np.ndarray] | None:
    """`planner_core.model.hoverlp.hover_lp` (the hover-time LP's one home), its HiGHS step
    looked up here at call time (`_highs_lp`), so that a test may count the calls.

    Args:
        R: link rates (I, J), Mbit/s.
        req: required data (J,), Mbit.
        t_max: the most hover time per point, s.
        warm: the warm-start store, as there (None: a cold start).

    Returns:
        (T (I,) s, sum T s, duals (J,)), or None when infeasible.
    """
    return _hover_lp(R, req, t_max, warm, highs=_highs_lp)


def _collected(problem: Problem, R: np.ndarray, times: np.ndarray) -> np.ndarray:
    """Data (J,) Mbit the hover times collect: R^T T (the paper's Q_j), or in scheduled access
    the most toward the requirements (`planner_core.model.kernels.scheduled_flow`)."""
    if getattr(problem, "scheduled", False):
        from planner_core.model.kernels import scheduled_flow

        return scheduled_flow(np.ascontiguousarray(R, dtype=float), np.asarray(times, float),
                              problem.required.astype(float), float(problem.bandwidth))
    return R.T @ times


def _hover_times(
    problem: Problem, R: np.ndarray, req: np.ndarray, feasible: bool, backend: str
) -> tuple[np.ndarray, str]:
    """Hover times (s) for rates R (I, J) Mbit/s: the hover-time LP (`_solve_lp`, topped up),
    or in scheduled access `planner_core.model.hoverlp.scheduled_lp` (T_i and the data D_ij
    taken from each sensor; HiGHS), raised by a hair until the max-flow allocation the
    evaluation uses meets every requirement; T_max everywhere when no times can."""
    if not getattr(problem, "scheduled", False):
        times, solver = _solve_lp(R, req, problem.t_max, feasible, backend)
        if feasible:
            times = _top_up(R, req, times, problem.t_max)
        return times, solver
    from planner_core.model.hoverlp import scheduled_lp

    t_max = float(problem.t_max)
    sol = scheduled_lp(R, req, float(problem.bandwidth), t_max) if feasible else None
    if sol is None:
        return np.full(R.shape[0], t_max), "scheduled: T_max everywhere (infeasible)"
    return _raise_to_flow(problem, R, req, sol[0]), "scheduled LP (HiGHS, highspy)"


def _raise_to_flow(problem: Problem, R: np.ndarray, req: np.ndarray,
                   times: np.ndarray) -> np.ndarray:
    """Scheduled access: the LP's hover times (I,) s, within solver tolerance, raised by a
    hair (at most 5 rounds, each at most 1e-6 and 1e-12 s) until the max-flow allocation the
    evaluation uses (`_collected`) meets every requirement, at most T_max each."""
    t_max = float(problem.t_max)
    for _ in range(5):
        got = _collected(problem, R, times)
        short = (req > 0) & (got < req)
        if not short.any():
            break
        ratio = float(np.max(req[short] / np.maximum(got[short], 1e-300)))
        times = np.minimum(times * min(ratio * (1 + 1e-12), 1.0 + 1e-6) + 1e-12, t_max)
    return times


def scheduled_hover_lp(
    problem: Problem, R: np.ndarray
) -> tuple[np.ndarray, float, np.ndarray] | None:
    """The hover-time LP of scheduled access (`radio.access` "scheduled") for the local search
    (`planner_core.search.descent.objective`, the structural moves, kicks and rebuilds): what
    `hover_lp` is to simultaneous access, through
    `planner_core.model.hoverlp.scheduled_lp_links`, its times raised by a hair as the polish
    raises them (`_raise_to_flow`), so that the evaluation's max-flow allocation serves every
    sensor.

    Args:
        problem: the UAV `Problem` (required data, T_max, R_lambda).
        R: the hover points' link rates (I, J), Mbit/s.

    Returns:
        (T (I,) s, V = sum T s, L (I, J) >= 0: dV/dR_ij = -L_ij T_i), or None when no hover
        times within T_max serve every sensor.
    """
    from planner_core.model.hoverlp import scheduled_lp_links

    req = problem.required.astype(float)
    sol = scheduled_lp_links(np.ascontiguousarray(R, dtype=float), req,
                             float(problem.bandwidth), float(problem.t_max))
    if sol is None:
        return None
    times = _raise_to_flow(problem, R, req, sol[0])
    return times, float(times.sum()), sol[2]


def _unserved_scheduled(problem: Problem, R: np.ndarray) -> list[dict[str, Any]]:
    """`_unserved` in scheduled access: the sensors short even at T_max everywhere, the
    bandwidth shared by the max-flow allocation (`_collected`)."""
    req = problem.required.astype(float)
    got = (_collected(problem, R, np.full(len(R), float(problem.t_max))) if len(R)
           else np.zeros(len(req)))  # fmt: skip
    out = []
    for j, sid in enumerate(problem.map.sensor_ids):
        need = float(req[j])
        if need <= 0 or got[j] >= need * (1 - 1e-12):
            continue
        if len(R) == 0 or not np.any(R[:, j] > 0):
            reason = "out of radio range of every hover point"
        else:
            reason = "T_max too small for the shared bandwidth"
        msg = (f"sensor '{sid}': {reason}: hovering T_max = {problem.t_max:g} s at every "
               f"point collects {got[j]:.6g} of {need:g} Mbit (scheduled access)")
        out.append({"sensor": sid, "reason": reason, "required": need,
                    "max_collectable": float(got[j]), "message": msg})  # fmt: skip
    return out


def polish_hover_times(
    problem: Problem,
    hover_points: np.ndarray,
    *,
    backend: str = "highs",
) -> PolishResult:
    """Solve the hover-time LP for these positions and drop points whose time is ~0 when safe.

    `backend` is "highs" (the default, quick: `hover_lp`, the LP by blocks, small ones in a
    compiled kernel, larger ones through highspy), "linprog" (HiGHS through scipy on the whole
    LP, the reference) or "cvxpy"; same LP (`BACKENDS`). In scheduled access (`radio.access`)
    the LP is `planner_core.model.hoverlp.scheduled_lp` (the data from each sensor a variable,
    the point's total within R_lambda T_i; HiGHS whatever the backend) and C3 is not reported.
    The plan's own hover times play no part: the LP chooses them from the positions alone.

    Args:
        problem: the `Problem` (its sensors, radio, T_max and obstacles).
        hover_points: (n, 2) hover positions in metres, in flying order.
        backend: the LP's solver, one of `BACKENDS`.

    Returns:
        The kept points (m, 2), their hover times (m,) in seconds, the indices dropped, whether
        C4 can be met, the sensors it cannot serve and why, the C3 excess and the solver used.
    """
    pts = np.asarray(hover_points, dtype=float).reshape(-1, 2)
    req = problem.required.astype(float)
    R = problem.rates(pts) if len(pts) else np.zeros((0, len(req)))
    scheduled = bool(getattr(problem, "scheduled", False))
    unserved = _unserved_scheduled(problem, R) if scheduled else _unserved(problem, R)
    feasible = not unserved
    solver = ""
    if len(pts):
        times, solver = _hover_times(problem, R, req, feasible, backend)
    else:
        times = np.zeros(0)
    keep = np.ones(len(pts), dtype=bool)
    if problem.variable_length:
        changed = True
        while changed:
            changed = False
            kept_overlap = _route_overlap(problem, pts[keep])
            kept_flight = _route_flight_time(problem, pts[keep])
            for i in np.flatnonzero(keep & (times <= ZERO_TIME)):
                trial = keep.copy()
                trial[i] = False
                # a collision-free path must stay so; a colliding one must not get worse
                if _dropped_overlap(problem, pts, keep, i, kept_overlap) > kept_overlap:
                    continue
                if _route_flight_time(problem, pts[trial]) > kept_flight:
                    continue
                keep = trial
                changed = True
                break
        # dropping a ~0 s point may leave a sliver of data uncollected: re-solve on the kept points
        if not keep.all() and keep.any():
            times_k, solver_k = _hover_times(problem, R[keep], req, feasible, backend)
            if feasible and np.any(_collected(problem, R[keep], times_k) < req):
                keep = np.ones(len(pts), dtype=bool)  # the kept points fall short: drop none
            else:
                times, solver = np.zeros(len(pts)), solver_k
                times[keep] = times_k
    c3 = 0.0 if scheduled else float(np.maximum(R[keep].sum(axis=1) - problem.bandwidth,
                                                0.0).sum())  # fmt: skip
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

    The caller evaluates them (and counts those evaluations) and keeps the best.

    Args:
        problem: the UAV `Problem`.
        X: the population (n, d), problem space.
        f: its objectives (n,).
        phi: its violations (n,).
        k: the most rows (a k < 1 still polishes the first).

    Returns:
        (the polished decision vectors (m, d), m <= max(k, 1), in Deb order of the inputs;
        their `PolishResult`s).
    """
    from planner_core.model.formulas import deb_order

    X = np.asarray(X, dtype=float)
    out, results, seen = [], [], set()
    for i in deb_order(np.asarray(f, dtype=float), np.asarray(phi, dtype=float)):
        key = X[i].tobytes()
        if key in seen:
            continue
        seen.add(key)
        b = problem.breakdown(X[i])
        pol = polish_hover_times(problem, b["hover_points"])
        out.append(problem.encode(pol.hover_points, pol.hover_times))
        results.append(pol)
        if len(out) >= k:
            break
    return np.asarray(out, dtype=float).reshape(len(out), X.shape[1]), results
