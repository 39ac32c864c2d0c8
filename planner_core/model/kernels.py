"""Compiled (numba) fast path of the model terms, one pass per solution.

`Problem.evaluate` calls `model_terms` for the population, then the geometry kernel for the legs
it wrote. It computes exactly what the numpy path of `Problem._evaluate_parts` computes (that path
stays as the readable reference and feeds `breakdown`); a test holds the two together. Inactive
hover points are skipped outright, which the numpy path cannot do. The per-leg formulas (Eq. 1,
the link rate) are the compiled scalars of `planner_core.model.formulas`; the parameters are the
fields of
the problem's `ModelParams`.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from planner_core.model.formulas import leg_time, slant_rate

__all__ = ["model_terms"]


@njit(cache=True, fastmath=False)
def model_terms(
    X, n_points, variable, tau, upper, start, end, sensors, required, altitude,
    peak_rate, decay, bandwidth, v_max, accel, alpha, A, B, f, v3, v4,
):  # fmt: skip
    """Fill f, v3, v4 (n,) and leg endpoints A, B (n, I_max + 1, 2) for population X (n, 4 I)."""
    n = X.shape[0]
    J = sensors.shape[0]
    h2 = altitude * altitude
    Q = np.empty(J)
    for s in range(n):
        for j in range(J):
            Q[j] = 0.0
        px = start[0]
        py = start[1]
        k = 0
        t_fly = 0.0
        t_hover = 0.0
        c3 = 0.0
        for i in range(n_points):
            base = 4 * i
            eps = min(max(X[s, base + 3], 0.0), 1.0)
            if variable and eps < tau:
                continue
            x = min(max(X[s, base], 0.0), upper[base])
            y = min(max(X[s, base + 1], 0.0), upper[base + 1])
            t = min(max(X[s, base + 2], 0.0), upper[base + 2])
            A[s, k, 0] = px
            A[s, k, 1] = py
            B[s, k, 0] = x
            B[s, k, 1] = y
            k += 1
            t_fly += leg_time(math.hypot(x - px, y - py), v_max, accel)
            t_hover += t
            total = 0.0
            for j in range(J):
                dx = x - sensors[j, 0]
                dy = y - sensors[j, 1]
                r = slant_rate(dx * dx + dy * dy, h2, peak_rate, decay)
                if r > 0.0:
                    total += r
                    Q[j] += r * t
            if total > bandwidth:
                c3 += total - bandwidth
            px = x
            py = y
        A[s, k, 0] = px
        A[s, k, 1] = py
        B[s, k, 0] = end[0]
        B[s, k, 1] = end[1]
        t_fly += leg_time(math.hypot(end[0] - px, end[1] - py), v_max, accel)
        for m in range(k + 1, n_points + 1):  # unused legs: zero length at the end point
            A[s, m, 0] = end[0]
            A[s, m, 1] = end[1]
            B[s, m, 0] = end[0]
            B[s, m, 1] = end[1]
        short = 0.0
        for j in range(J):
            if required[j] > Q[j]:
                short += required[j] - Q[j]
        f[s] = alpha * t_fly + (1.0 - alpha) * t_hover
        v3[s] = c3
        v4[s] = short
