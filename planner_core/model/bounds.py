"""A lower bound on the objective f of any feasible plan, so results can be read against it.

    LB = alpha * T_fly(|end - start|) + (1 - alpha) * H_LB

Flight: any path start -> p_1 -> ... -> end is at least |end - start| long (triangle inequality)
and T_fly is increasing and concave with T_fly(0) = 0, hence subadditive, so the summed leg times
are at least T_fly(|end - start|).

Hover: H_LB is the minimum total hover time of an LP that relaxes C3, C5 and the flight. The area
is cut into square-ish cells (side <= `spacing`, 25 m by default); cell c gets, for each sensor j,
the largest rate any point of the cell can have (R_c - xi * sqrt(d_min(c, s_j)^2 + H^2), d_min =
distance from the sensor to the cell), so every hover point of a real plan is dominated by its
cell. Only cells within radio range of at least one sensor enter the LP:

    minimise sum_c T_c  s.t.  sum_c Rbar_cj T_c >= Q_j (all j),  0 <= T_c <= I_max * T_max,
                              sum_c T_c <= I_max * T_max.

The per-cell cap is I_max * T_max, not T_max, because one cell may hold several hover points of
a real plan (each <= T_max); with per-cell maximal rates and that cap the LP is a true relaxation,
so LB <= f of every feasible plan (an LP over grid *points* is not: an off-grid hover point may
beat every grid point). On the suite the caps never bind (a sensor needs ~22 s at ~9 Mbit/s).
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass
from typing import Any

import numpy as np

from planner_core.model.formulas import ModelParams, flight_time, ground_reach, slant_rates
from planner_core.model.mapio import Map, load_map

__all__ = ["LowerBound", "lower_bound", "hover_lower_bound", "DEFAULT_SPACING"]

#: the largest cell side, metres
DEFAULT_SPACING = 25.0


@dataclass(frozen=True)
class LowerBound:
    """LB and its two parts, with the LP's size; `lb` is inf when some sensor cannot be served."""

    lb: float
    flight_lb: float  # T_fly(|end - start|), seconds (not yet weighted by alpha)
    hover_lb: float  # H_LB, seconds (not yet weighted by 1 - alpha)
    alpha: float
    spacing: float  # the cell side actually used (<= the requested spacing)
    n_candidates: int  # cells in radio range of at least one sensor (LP variables)
    status: str  # "optimal", or why not

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready fields.

        Returns:
            {lb, flight_lb, hover_lb, alpha, spacing, n_candidates, status} (`asdict`).
        """
        return asdict(self)


def _cell_rates(m: Map, spacing: float) -> tuple[np.ndarray, np.ndarray, np.ndarray, float]:
    """Sparse (row = sensor, col = candidate cell, value = max rate over the cell) and the side."""
    mp = ModelParams.from_map(m)
    H, rc, xi = mp.altitude, mp.peak_rate, mp.decay
    nx = max(1, math.ceil(m.width / spacing))
    ny = max(1, math.ceil(m.height / spacing))
    wx, wy = m.width / nx, m.height / ny
    reach = float(ground_reach(0.0, H, rc, xi))  # cells beyond it get no rate at all
    rows, cols, vals = [], [], []
    for j, (sx, sy) in enumerate(m.sensors):
        i0 = max(0, math.floor((sx - reach) / wx))
        i1 = min(nx - 1, math.floor((sx + reach) / wx))
        k0 = max(0, math.floor((sy - reach) / wy))
        k1 = min(ny - 1, math.floor((sy + reach) / wy))
        ix = np.arange(i0, i1 + 1)
        ky = np.arange(k0, k1 + 1)
        # distance from the sensor to each cell along each axis (0 when inside the cell's span)
        dx = np.maximum(np.maximum(ix * wx - sx, sx - (ix + 1) * wx), 0.0)
        dy = np.maximum(np.maximum(ky * wy - sy, sy - (ky + 1) * wy), 0.0)
        d2 = dx[:, None] ** 2 + dy[None, :] ** 2
        rate = slant_rates(d2, H, rc, xi)
        ii, kk = np.nonzero(rate > 0)
        rows.append(np.full(len(ii), j))
        cols.append(ix[ii] * ny + ky[kk])
        vals.append(rate[ii, kk])
    if not rows:
        return np.empty(0, int), np.empty(0, int), np.empty(0), max(wx, wy)
    return np.concatenate(rows), np.concatenate(cols), np.concatenate(vals), max(wx, wy)


def hover_lower_bound(
    m: Map | str | dict, spacing: float = DEFAULT_SPACING
) -> tuple[float, int, float, str]:
    """H_LB (seconds), the number of candidate cells, the cell side used, and the LP status.

    Args:
        m: a loaded map, a map file path or its dict (`load_map`).
        spacing: the largest cell side, m (> 0).

    Returns:
        (H_LB s, candidate cells, cell side m, status): (0, 0, side, "optimal") when no sensor
        needs data; H_LB inf with status "infeasible: ..." when a sensor that needs data is
        out of radio range of the whole area, or the solver's status when the LP is not
        solved to optimality. H_LB is the solver's optimum less a relative 1e-7 (its
        tolerance), at least 0.

    Raises:
        ValueError: spacing <= 0.
        MapError: `m` is not a valid map (`load_map`).
    """
    import cvxpy as cp
    import scipy.sparse as sp

    m = load_map(m)
    if spacing <= 0:
        raise ValueError(f"spacing must be positive, got {spacing}")
    req = np.asarray(m.required_data, dtype=float)
    rows, cols, vals, side = _cell_rates(m, float(spacing))
    need = req > 0
    if not need.any():
        return 0.0, 0, side, "optimal"
    served = np.zeros(len(req), dtype=bool)
    served[rows] = True
    if not served[need].all():
        return math.inf, 0, side, "infeasible: a sensor is out of radio range of the whole area"
    cells, col = np.unique(cols, return_inverse=True)
    n = len(cells)
    # rows scaled so each sensor needs 1 unit (keeps the LP well conditioned)
    keep = need[rows]
    A = sp.csr_matrix(
        (vals[keep] / req[rows[keep]], (rows[keep], col[keep])), shape=(len(req), n)
    )[need]
    cap = m.max_hover_points * m.spec.uav.max_hover_time
    T = cp.Variable(n)
    prob = cp.Problem(cp.Minimize(cp.sum(T)), [A @ T >= 1.0, T >= 0, T <= cap, cp.sum(T) <= cap])
    if "HIGHS" in cp.installed_solvers():
        from planner_core.model.hoverlp import quiet_highs

        quiet_highs()  # else cvxpy's HiGHS prints highspy's banner on stdout (`report`'s)
        prob.solve(solver="HIGHS")
    else:
        prob.solve()
    if prob.status not in ("optimal", "optimal_inaccurate"):
        return math.inf, n, side, str(prob.status)
    # the solver's optimum can sit a hair above the exact LP value; step down by its tolerance
    value = float(prob.value) * (1.0 - 1e-7)
    return max(value, 0.0), n, side, str(prob.status)


def lower_bound(m: Map | str | dict, spacing: float = DEFAULT_SPACING) -> LowerBound:
    """LB = alpha * T_fly(|end - start|) + (1 - alpha) * H_LB for map `m` (see module docstring).

    Args:
        m: a loaded map, a map file path or its dict (`load_map`).
        spacing: the largest cell side of the hover LP, m (> 0).

    Returns:
        The `LowerBound` (seconds). With alpha = 1 the hover part is dropped, so `lb` stays
        finite even when H_LB is inf (see `status`).

    Raises:
        ValueError: spacing <= 0.
        MapError: `m` is not a valid map (`load_map`).
    """
    m = load_map(m)
    mp = ModelParams.from_map(m)
    alpha = mp.alpha
    fly = float(flight_time(np.linalg.norm(mp.end - mp.start), mp.v_max, mp.accel))
    hover, n, side, status = hover_lower_bound(m, spacing)
    lb = alpha * fly + ((1.0 - alpha) * hover if alpha < 1.0 else 0.0)
    return LowerBound(
        lb=lb,
        flight_lb=fly,
        hover_lb=hover,
        alpha=alpha,
        spacing=side,
        n_candidates=n,
        status=status,
    )
