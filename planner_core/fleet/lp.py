"""The hover-time LP across sorties: for fixed routes, the hover times of every sortie at once.

With the routes fixed, a sortie's energy is linear in its hover times
(`planner_core.model.energy`: E = E_flight(route) + P(0) / 3600 x sum t), so the paper's
hover-time LP (`planner_core.model.hoverlp`) extends to a fleet plan by one row per sortie:

    minimise   sum_i t_i                                   ("total": the hover part of sum f)
      or       z + EPS sum_i t_i                           ("makespan")
    s.t.       sum_i R_ij t_i >= Q_j      every sensor j, over the points of ALL sorties (C4:
                                          a sensor's data may come from several sorties)
               P(0)/3600 sum_{i in s} t_i <= budget_s - E_flight_s          every sortie s
               sum_{i in v} t_i - z <= -(flight, take-offs, landings, swaps of vehicle v)
               0 <= t_i <= T_max,   t_i = 0 where point i breaks C3

Under the paper's simultaneous uplink (`radio.access` "simultaneous") a point whose summed
link rate exceeds the bandwidth R_lambda may be flown through (a detour corner, 0 s) but not
hovered at: its time is held at 0, so every hover point of the result keeps C3 (the sortie
planner's moves join detour corners and insert points that its sub-runs never checked).

`budget_s` is the usable energy less the planner's allowance for storage
(`FleetSettings.budget_wh`). Solved whole by HiGHS (`scipy.optimize.linprog`), then topped up
(`planner_core.model.hoverlp.top_up`) so C4 holds exactly. Cost: one LP of N = all points
variables and J + S (+ V) rows, O(N x J) to build (the link rates).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from planner_core.fleet.model import FleetPlan
from planner_core.model.hoverlp import TARGET, top_up

__all__ = ["EPS", "fleet_hover_lp", "collected_by_sortie"]

#: weight of the hover times beside the makespan (keeps the LP from hovering longer than needed
#: on the vehicles that are not the longest)
EPS = 1e-3


def _stack(plan: FleetPlan) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(points (N, 2), sortie index (N,), vehicle index (N,)) over every sortie."""
    pts, sid, vid = [], [], []
    k = 0
    for v, sorties in enumerate(plan.vehicles):
        for s in sorties:
            pts.append(s.points)
            sid.append(np.full(len(s.points), k))
            vid.append(np.full(len(s.points), v))
            k += 1
    if not pts:
        return np.zeros((0, 2)), np.zeros(0, dtype=int), np.zeros(0, dtype=int)
    return np.vstack(pts), np.concatenate(sid), np.concatenate(vid)


def fleet_hover_lp(plan: FleetPlan, model: Any, goal: str | None = None) -> FleetPlan | None:
    """The plan with every hover time re-solved by the LP across sorties (module docstring).

    Args:
        plan: the routes (their hover times are replaced).
        model: the planning map's `planner_core.model.formulas.ModelParams` (rates, required
            data with the data margin, T_max).
        goal: "total" or "makespan" (default: the plan's settings'); any other value is
            solved as "total".

    Returns:
        The re-timed plan, or None when no hover times meet C4 within every sortie's energy
        at points that keep C3.
    """
    from scipy import sparse
    from scipy.optimize import linprog

    st = plan.settings
    goal = goal or st.goal
    P, sid, vid = _stack(plan)
    sorties = plan.sorties
    N, S, V = len(P), len(sorties), len(plan.vehicles)
    req = np.asarray(model.required, dtype=float)
    need = np.flatnonzero(req > 0)
    if N == 0:
        return plan if not len(need) else None
    R = model.rates(P)  # (N, J) Mbit/s
    # C3: no hover time where the summed rate exceeds the bandwidth (module docstring)
    c3_bad = R.sum(axis=1) > model.bandwidth
    if model.access != "simultaneous":
        c3_bad[:] = False
    A_cov = -(R[:, need] / req[need]).T  # (J', N)
    h = st.hover_w / 3600.0
    A_en = sparse.csr_matrix((np.full(N, h), (sid, np.arange(N))), shape=(S, N))
    b_en = np.array([st.budget_wh(len(s.points)) - s.flight_wh(st) for s in sorties])
    if not np.all(np.isfinite(b_en)):  # no battery: no energy rows
        A_en = sparse.csr_matrix((0, N))
        b_en = np.zeros(0)
    S = len(b_en)
    t_max = float(model.t_max)
    caps = [(0.0, 0.0) if bad else (0.0, t_max) for bad in c3_bad]
    if goal == "makespan":
        base = np.zeros(V)
        for v, vs in enumerate(plan.vehicles):
            base[v] = sum(s.t_fly(st) + st.vertical_s for s in vs) + st.swap_s * (len(vs) - 1)
        A_mk = sparse.hstack(
            [
                sparse.csr_matrix((np.ones(N), (vid, np.arange(N))), shape=(V, N)),
                sparse.csr_matrix(-np.ones((V, 1))),
            ]
        )
        A = sparse.vstack(
            [
                sparse.hstack([sparse.csr_matrix(A_cov), sparse.csr_matrix((len(need), 1))]),
                sparse.hstack([A_en, sparse.csr_matrix((S, 1))]),
                A_mk,
            ]
        ).tocsr()
        b = np.concatenate([np.full(len(need), -TARGET), b_en, -base])
        c = np.concatenate([np.full(N, EPS), [1.0]])
        bounds = caps + [(0.0, None)]
    else:
        A = sparse.vstack([sparse.csr_matrix(A_cov), A_en]).tocsr()
        b = np.concatenate([np.full(len(need), -TARGET), b_en])
        c = np.ones(N)
        bounds = caps
    res = linprog(c, A_ub=A, b_ub=b, bounds=bounds, method="highs")
    if res.status != 0:
        return None
    T = np.clip(np.asarray(res.x[:N], dtype=float), 0.0, t_max)
    T = top_up(np.where(c3_bad[:, None], 0.0, R), req, T, t_max)
    T[c3_bad] = 0.0  # the top-up's 1e-12 s floor stays off them
    out: list[list[Any]] = []
    k = 0
    for vs in plan.vehicles:
        row = []
        for s in vs:
            n = len(s.points)
            row.append(s.with_times(T[k : k + n]))
            k += n
        out.append(row)
    return plan.replace(out)


def collected_by_sortie(plan: FleetPlan, model: Any) -> np.ndarray:
    """Data each sortie collects from each sensor: sum over its points of R_ij t_i (the
    paper's Q_j, Sec. 3, per sortie; C4 holds when each column sums to at least the required).

    Args:
        plan: the plan; its sorties in `FleetPlan.sorties` order (vehicle by vehicle).
        model: the planning map's `planner_core.model.formulas.ModelParams` (`rates` in
            Mbit/s, `required` in Mbit).

    Returns:
        (S, J) Mbit, S sorties by J sensors (a sortie without points: a row of zeros).
    """
    rows = []
    for s in plan.sorties:
        if len(s.points):
            rows.append(s.times @ model.rates(s.points))
        else:
            rows.append(np.zeros(len(model.required)))
    return np.array(rows).reshape(-1, len(model.required))
