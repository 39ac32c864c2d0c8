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

from planner_core.model.formulas import leg_time, slant_rate, window_range

__all__ = ["model_terms", "scheduled_flow"]


@njit(cache=True, fastmath=False, nogil=True)
def scheduled_flow(R, t, Q, bandwidth):  # pragma: no cover - compiled
    """Scheduled access (`radio.access` "scheduled"): the most data the hover times can take
    toward the requirements, per sensor (J,) Mbit.

    The allocation D_ij <= R_ij t_i, sum_j D_ij <= R_lambda t_i is a flow from the points to
    the sensors (capacities R_lambda t_i, R_ij t_i, Q_j); its maximum (Edmonds-Karp, BFS
    augmenting paths) leaves the least total shortfall sum_j (Q_j - F_j), F_j = sum_i D_ij
    <= Q_j. A point within its bandwidth (sum_j R_ij <= R_lambda) sends every link in full
    first (what any allocation may do); the saturated ones are then augmented. The paths are
    capped (k J + k + J of them): stopping early only under-counts, never over-counts.

    Args:
        R: (k, J) link rates, Mbit/s, of k hover points.
        t: (k,) hover times, s.
        Q: (J,) required data, Mbit.
        bandwidth: R_lambda, Mbit/s.

    Returns:
        F (J,) Mbit: the data each sensor delivers, F_j <= Q_j.
    """
    k, J = R.shape
    F = np.zeros(J)
    cap_pt = np.empty(k)  # residual bandwidth per point, Mbit
    D = np.zeros((k, J))
    for i in range(k):
        total = 0.0
        for j in range(J):
            total += R[i, j]
        cap_pt[i] = bandwidth * t[i]
        if total <= bandwidth:  # within its bandwidth: every link in full, up to the need
            for j in range(J):
                d = min(R[i, j] * t[i], max(Q[j] - F[j], 0.0))
                if d > 0.0:
                    D[i, j] = d
                    F[j] += d
                    cap_pt[i] -= d
    eps = 1e-12 * max(np.max(Q) if J else 0.0, 1.0)
    # BFS over nodes: 0..k-1 points, k..k+J-1 sensors; parent arrays for the path
    par = np.empty(k + J, dtype=np.int64)
    queue = np.empty(k + J, dtype=np.int64)
    for _ in range(k * J + k + J):
        for v in range(k + J):
            par[v] = -2
        head, tail = 0, 0
        for i in range(k):
            if cap_pt[i] > eps:
                par[i] = -1
                queue[tail] = i
                tail += 1
        end = -1
        while head < tail and end < 0:
            v = queue[head]
            head += 1
            if v < k:
                for j in range(J):
                    w = k + j
                    if par[w] == -2 and R[v, j] * t[v] - D[v, j] > eps:
                        par[w] = v
                        if Q[j] - F[j] > eps:
                            end = w
                            break
                        queue[tail] = w
                        tail += 1
            else:
                j = v - k
                for i in range(k):
                    if par[i] == -2 and D[i, j] > eps:
                        par[i] = v
                        queue[tail] = i
                        tail += 1
        if end < 0:
            break
        # bottleneck along end <- ... <- a source point
        b = Q[end - k] - F[end - k]
        w = end
        while par[w] != -1:
            p = par[w]
            # p point -> w sensor (forward), or p sensor -> w point (a reverse edge)
            b = min(b, R[p, w - k] * t[p] - D[p, w - k] if w >= k else D[w, p - k])
            w = p
        b = min(b, cap_pt[w])
        if b <= eps:
            break
        cap_pt[w] -= b
        F[end - k] += b
        w = end
        while par[w] != -1:
            p = par[w]
            if w >= k:
                D[p, w - k] += b
            else:
                D[w, p - k] -= b
            w = p
    return F


@njit(cache=True, fastmath=False)
def model_terms(
    X, n_points, variable, tau, upper, start, end, sensors, required, altitude,
    peak_rate, decay, order, xs, half, bandwidth, v_max, accel, alpha, A, B, f, v3, v4,
    scheduled=False,
):  # fmt: skip
    """Fill f, v3, v4 (n,) and leg endpoints A, B (n, I_max + 1, 2) for population X (n, 4 I).

    order, xs, half: the sensors' `formulas.SensorWindow` (the range cut): each hover point
    visits only the sensors within `half` of it in x and y (found by a binary search of xs),
    in index order, so O(n I_max x sensors in range) instead of O(n I_max J) square roots;
    the pairs skipped have a rate <= 0, which adds nothing, so the same sums in the same order
    as every sensor visited (half = inf, the reference; tests).

    Args:
        X: (n, 4 I) decision vectors (x m, y m, t s, eps per slot), clipped to [0, upper].
        n_points: I, the slots.
        variable: variable-length encoding (a slot flies when eps >= tau); False: every slot.
        tau: the activation threshold.
        upper: (4 I,) the decision vector's upper bounds (width, height, T_max, 1 per slot).
        start: (2,) the mission's start, m.
        end: (2,) the mission's end, m.
        sensors: (J, 2) sensor positions, m.
        required: (J,) required data Q_j, Mbit.
        altitude: H, m.
        peak_rate: R_c, Mbit/s.
        decay: xi, Mbit/s per m.
        order: (J,) the sensors' indices by x (`SensorWindow.order`).
        xs: (J,) their x, sorted, m (`SensorWindow.xs`).
        half: the range cut, m (`SensorWindow.half`; inf: every sensor).
        bandwidth: R_lambda, Mbit/s.
        v_max: cruise speed, m/s.
        accel: acceleration a, m/s^2.
        alpha: the weight of flight against hover time.
        A: (n, I + 1, 2) out: leg starts, m (unused legs zero-length at the end point).
        B: (n, I + 1, 2) out: leg ends, m.
        f: (n,) out: alpha t_fly + (1 - alpha) t_hover, s (Eq. 1 leg times).
        v3: (n,) out: C3's excess over the bandwidth summed over the points, Mbit/s (0 when
            scheduled).
        v4: (n,) out: C4's shortfall summed over the sensors, Mbit.
        scheduled: radio.access "scheduled" (no C3; collected data from `scheduled_flow`).
    """
    n = X.shape[0]
    J = sensors.shape[0]
    h2 = altitude * altitude
    Q = np.empty(J)
    near = np.empty(J, dtype=np.int64)
    Rk = np.empty((n_points, J)) if scheduled else np.empty((0, J))
    Tk = np.empty(n_points) if scheduled else np.empty(0)
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
            if half < np.inf and math.isfinite(x) and math.isfinite(y):
                lo, hi = window_range(xs, half, x)
                m = 0
                for q in range(lo, hi):  # the sensors in range, then in index order
                    j = order[q]
                    if abs(y - sensors[j, 1]) < half:
                        u = m
                        while u > 0 and near[u - 1] > j:
                            near[u] = near[u - 1]
                            u -= 1
                        near[u] = j
                        m += 1
                if scheduled:  # the sensors out of range keep a rate of 0
                    for j in range(J):
                        Rk[k - 1, j] = 0.0
            else:  # every sensor (the reference, or a non-finite point)
                for j in range(J):
                    near[j] = j
                m = J
            for u in range(m):
                j = near[u]
                dx = x - sensors[j, 0]
                dy = y - sensors[j, 1]
                r = slant_rate(dx * dx + dy * dy, h2, peak_rate, decay)
                if scheduled:
                    Rk[k - 1, j] = max(r, 0.0)
                if r > 0.0:
                    total += r
                    Q[j] += r * t
            if scheduled:
                Tk[k - 1] = t
            elif total > bandwidth:
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
        if scheduled:
            F = scheduled_flow(Rk[:k], Tk[:k], required, bandwidth)
            for j in range(J):
                Q[j] = F[j]
        short = 0.0
        for j in range(J):
            if required[j] > Q[j]:
                short += required[j] - Q[j]
        f[s] = alpha * t_fly + (1.0 - alpha) * t_hover
        v3[s] = c3
        v4[s] = short
