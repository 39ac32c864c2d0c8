"""The paper's model, once: flight time (Eq. 1), link rate, Deb's rule, the penalised score, and
the frozen parameter record everything else reads them from (paper Sec. 3, Sec. 4.1, Sec. 5.2).

A leaf module: it imports nothing of the project but the import-free defaults table, so the
problem, the seeder, the map generator, the lower bound, the polish LP, the compiled kernels and
the baselines all take their formulas from here. Each formula comes in the form its callers
need: numpy over arrays and, where a compiled (numba) kernel needs it per element, an ``@njit``
scalar defined right next to it and held equal to it by a test. The sim (`sim.replay`) keeps
its own deliberate second implementation.

Units: metres, seconds, Mbit and Mbit/s; positions in the map's local ENU frame.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property
from typing import Any, NamedTuple

import numpy as np
from numba import njit

from planner_core.defaults import L_VIO_TOL as _L_VIO_TOL
from planner_core.defaults import SCORE_FACTOR

__all__ = [
    "PENALTY_FACTOR",
    "L_VIO_TOL",
    "ModelParams",
    "flight_time",
    "leg_time",
    "link_rates",
    "SensorWindow",
    "sensor_window",
    "window_pair_rate",
    "window_range",
    "numpy_sum",
    "ground_reach",
    "slant_rate",
    "slant_rate_grad",
    "slant_rates",
    "collision_penalty",
    "penalised_score",
    "deb_better",
    "deb_not_worse",
    "deb_best",
    "deb_order",
]

#: The factor of the penalised score f + 10 * phi used to compare optimisers (paper Sec. 5.2);
#: its value lives in the defaults table (`planner_core.defaults.SCORE_FACTOR`).
PENALTY_FACTOR = SCORE_FACTOR

#: The overlap tolerance (metres) shared with the sim; see `planner_core.defaults.L_VIO_TOL`.
L_VIO_TOL = _L_VIO_TOL


# ----------------------------------------------------------------------------- flight (Eq. 1)


def flight_time(d: np.ndarray, v_max: float, accel: float) -> np.ndarray:
    """Time to fly distance d from rest to rest (paper Eq. 1, Sec. 3.1): a trapezoid speed
    profile above d = v_max^2 / a (cruise at v_max), a triangle below.

    Args:
        d: leg lengths (m), any shape; d <= 0 takes 0 s.
        v_max: cruise speed v_max (m/s), > 0.
        accel: acceleration a (m/s^2), > 0.

    Returns:
        T_fly (s), d's shape (a 0-d array for a scalar d).
    """
    d = np.asarray(d, dtype=float)
    cruise = d > v_max * v_max / accel
    return np.where(cruise, d / v_max + v_max / accel, 2.0 * np.sqrt(np.maximum(d, 0.0) / accel))


@njit(cache=True, nogil=True)
def leg_time(d: float, v_max: float, accel: float) -> float:  # pragma: no cover - compiled
    """`flight_time` (Eq. 1) for one leg, for compiled kernels (bit-equal; tests/test_model.py).

    Args:
        d: the leg's length (m); d <= 0 takes 0 s.
        v_max: cruise speed (m/s), > 0.
        accel: acceleration a (m/s^2), > 0.

    Returns:
        T_fly (s).
    """
    if d > v_max * v_max / accel:
        return d / v_max + v_max / accel
    return 2.0 * math.sqrt(max(d, 0.0) / accel)


# ----------------------------------------------------------------------------- link rate


def slant_rates(d2: np.ndarray, altitude: float, peak_rate: float, decay: float) -> np.ndarray:
    """The link rate before its clip at 0, R_c - xi * sqrt(d^2 + H^2) (paper Sec. 3.1's R_ij).

    Args:
        d2: squared ground distances d^2 (m^2), any shape.
        altitude: flight altitude H (m).
        peak_rate: R_c (Mbit/s).
        decay: xi (Mbit/s per m of slant distance).

    Returns:
        Rates (Mbit/s), d2's shape; negative beyond the radio's reach.
    """
    return peak_rate - decay * np.sqrt(d2 + altitude**2)


@njit(cache=True, nogil=True)
def slant_rate(d2: float, h2: float, peak_rate: float, decay: float) -> float:  # pragma: no cover
    """`slant_rates` for one pair, for compiled kernels (bit-equal; tests/test_model.py).

    Args:
        d2: squared ground distance (m^2).
        h2: squared altitude H^2 (m^2).
        peak_rate: R_c (Mbit/s).
        decay: xi (Mbit/s per m).

    Returns:
        R_c - xi * sqrt(d2 + h2) (Mbit/s), not clipped at 0.
    """
    return peak_rate - decay * math.sqrt(d2 + h2)


@njit(cache=True, nogil=True)
def slant_rate_grad(dx: float, dy: float, h2: float, peak_rate: float,
                    decay: float) -> tuple[float, float, float]:  # pragma: no cover
    """`slant_rate` of one pair and its gradient with respect to the hover point, for compiled
    kernels: with r = sqrt(dx^2 + dy^2 + H^2), R = R_c - xi r and dR/dx = -xi dx / r, dR/dy =
    -xi dy / r (paper Sec. 3.1's R_ij, not clipped at 0; the rate is `slant_rate`'s to the
    bit, tests/test_model.py).

    Args:
        dx: point x minus sensor x (m).
        dy: point y minus sensor y (m).
        h2: squared altitude H^2 (m^2).
        peak_rate: R_c (Mbit/s).
        decay: xi (Mbit/s per m).

    Returns:
        (R (Mbit/s), dR/dx, dR/dy (Mbit/s per m)).
    """
    r = math.sqrt((dx * dx + dy * dy) + h2)
    return peak_rate - decay * r, -(decay * dx / r), -(decay * dy / r)


def ground_reach(
    rate: np.ndarray | float, altitude: float, peak_rate: float, decay: float
) -> np.ndarray:
    """The link rate (Sec. 3.1) read backwards: the largest ground distance at which the rate
    is still at least `rate`, sqrt(((R_c - rate) / xi)^2 - H^2).

    Args:
        rate: the rates wanted (Mbit/s), a float or an array of any shape.
        altitude: H (m).
        peak_rate: R_c (Mbit/s).
        decay: xi (Mbit/s per m); 0 counts as 1e-12 (a reach of ~1e13 m).

    Returns:
        Ground distances (m), rate's shape (a numpy float for a float); 0 where not even the
        point overhead reaches the rate (rate >= R_c - xi H).
    """
    slant = np.maximum(peak_rate - rate, 0.0) / max(decay, 1e-12)
    return np.sqrt(np.maximum(slant * slant - altitude**2, 0.0))


def link_rates(
    pts: np.ndarray, sensors: np.ndarray, altitude: float, peak_rate: float, decay: float,
    window: SensorWindow | None = None,
) -> np.ndarray:
    """The link rates R_ij = max(R_c - xi * sqrt(|p_i - s_j|^2 + H^2), 0) (paper Sec. 3.1).

    One (I, 2) float64 set of points takes the compiled `_link_rates_2d` (bit-equal: the same
    operations in the same order; tests), or with `window` `_link_rates_window`: only the
    sensors within radio range in x of each point are computed, O(I x sensors in range) plus
    O(I J) to zero the array, instead of O(I J) square roots (the same array; tests).

    Args:
        pts: hover points p_i (m), shape (..., I, 2).
        sensors: sensor positions s_j (m), a numpy array of shape (J, 2).
        altitude: H (m).
        peak_rate: R_c (Mbit/s).
        decay: xi (Mbit/s per m).
        window: `sensor_window` of these same sensors and radio (None: no range cut); used
            for a 2-D float64 `pts` only.

    Returns:
        R (Mbit/s, >= 0), shape (..., I, J).
    """
    pts = np.asarray(pts)
    if pts.ndim == 2 and pts.dtype == np.float64 and sensors.dtype == np.float64:
        if window is not None and math.isfinite(window.half):
            return _link_rates_window(pts, sensors, window.order, window.xs, window.half,
                                      altitude**2, peak_rate, decay)
        return _link_rates_2d(pts, sensors, altitude**2, peak_rate, decay)
    dx = pts[..., :, None, 0] - sensors[:, 0]
    dy = pts[..., :, None, 1] - sensors[:, 1]
    rate = slant_rates(dx * dx + dy * dy, altitude, peak_rate, decay)
    return np.maximum(rate, 0.0, out=rate)


@njit(cache=True, nogil=True)
def _link_rates_2d(pts, sensors, h2, peak_rate, decay):  # pragma: no cover - compiled
    """`link_rates` of points (I, 2) to sensors (J, 2): (I, J) Mbit/s."""
    out = np.empty((pts.shape[0], sensors.shape[0]))
    for i in range(pts.shape[0]):
        for j in range(sensors.shape[0]):
            dx = pts[i, 0] - sensors[j, 0]
            dy = pts[i, 1] - sensors[j, 1]
            out[i, j] = max(slant_rate(dx * dx + dy * dy, h2, peak_rate, decay), 0.0)
    return out


class SensorWindow(NamedTuple):
    """The sensors sorted by x, for the link rate's range cut (`sensor_window`): `order` (J,)
    their indices by x, `xs` (J,) their x in that order, `half` (m): a point whose computed
    |dx| or |dy| to a sensor is at least `half` gets a rate <= 0 from `slant_rate` (inf: no
    cut, e.g. xi = 0)."""

    order: np.ndarray
    xs: np.ndarray
    half: float


def sensor_window(sensors: np.ndarray, altitude: float, peak_rate: float, decay: float
                  ) -> SensorWindow:
    """The sensors sorted by x with the radio's range cut, for the compiled rate loops.

    The cut is exact, not a tolerance: `slant_rate` is non-increasing in its computed d2 (each
    operation is monotone and rounding is monotone), c is a d2 a hair beyond the zero of the
    rate at which `slant_rate` itself gives <= 0 (checked), and |dx| >= half = sqrt(c)
    (1 + 1e-9) makes the computed d2 >= dx^2 (1 - 2^-53) > c. A kernel may therefore skip
    every pair with |dx| or |dy| >= half, and only those, and write the rate 0 (or add
    nothing) there.

    Args:
        sensors: sensor positions (m), anything numpy reads as J pairs, e.g. (J, 2).
        altitude: H (m).
        peak_rate: R_c (Mbit/s).
        decay: xi (Mbit/s per m); xi <= 0 or a non-finite radio gives no cut.

    Returns:
        The `SensorWindow`: `order` (J,) int64, `xs` (J,) m, `half` m (inf: no cut).
    """
    S = np.asarray(sensors, dtype=float).reshape(-1, 2)
    order = np.argsort(S[:, 0], kind="stable").astype(np.int64)
    xs = np.ascontiguousarray(S[order, 0])
    half = math.inf
    h2 = altitude * altitude
    if decay > 0.0 and math.isfinite(peak_rate) and math.isfinite(h2):
        ratio = peak_rate / decay
        if math.isfinite(ratio):
            c = max(ratio * ratio - h2, 0.0) * (1.0 + 1e-6) + 1e-6
            if math.isfinite(c) and slant_rate(c, h2, peak_rate, decay) <= 0.0:
                half = math.sqrt(c) * (1.0 + 1e-9)
    return SensorWindow(order, xs, half)


@njit(cache=True, nogil=True)
def window_range(xs, half, px):  # pragma: no cover - compiled
    """The slice of the x-sorted sensors that may lie within `half` of x = px, for kernels.

    Every sensor outside it has |fl(px - x)| >= half (margin 1e-9 of half and of |px| for the
    rounding of px -/+ the width).

    Args:
        xs: the sensors' x (m), sorted, shape (J,) (`SensorWindow.xs`).
        half: the range cut (m), `SensorWindow.half`.
        px: the point's x (m); must be finite.

    Returns:
        (lo, hi): the indices [lo, hi) into xs (and `SensorWindow.order`) to visit.
    """
    w = half * (1.0 + 1e-9) + 1e-9 * abs(px)
    return np.searchsorted(xs, px - w, side="left"), np.searchsorted(xs, px + w, side="right")


@njit(cache=True, nogil=True)
def _link_rates_window(pts, sensors, order, xs, half, h2, peak_rate, decay):  # pragma: no cover
    """`_link_rates_2d` with the range cut of `sensor_window`: (I, J) Mbit/s, zeros written
    where |dx| or |dy| >= half (the rate there is <= 0, clipped to 0), each other pair as
    `_link_rates_2d` computes it; a point with a non-finite coordinate takes every sensor."""
    n, J = pts.shape[0], sensors.shape[0]
    out = np.zeros((n, J))
    for i in range(n):
        px, py = pts[i, 0], pts[i, 1]
        if not (math.isfinite(px) and math.isfinite(py)):
            for j in range(J):
                dx = px - sensors[j, 0]
                dy = py - sensors[j, 1]
                out[i, j] = max(slant_rate(dx * dx + dy * dy, h2, peak_rate, decay), 0.0)
            continue
        lo, hi = window_range(xs, half, px)
        for q in range(lo, hi):
            j = order[q]
            out[i, j] = window_pair_rate(px, py, sensors[j, 0], sensors[j, 1], half, h2,
                                         peak_rate, decay)
    return out


@njit(cache=True, nogil=True, inline="always")
def window_pair_rate(px, py, sx, sy, half, h2, peak_rate, decay):  # pragma: no cover - compiled
    """The link rate (Mbit/s) of the point (px, py) to the sensor (sx, sy) under the range cut
    of `sensor_window`, for compiled kernels: 0 where |dy| >= half, else `slant_rate` clipped
    at 0 (what `_link_rates_window` writes for the pair; the range cut in x is its caller's,
    `window_range`). O(1).

    Args:
        px, py: the point (m); sx, sy: the sensor (m).
        half: the range cut (m), `SensorWindow.half`.
        h2: H^2 (m^2); peak_rate: R_c (Mbit/s); decay: xi (Mbit/s per m).

    Returns:
        The rate, Mbit/s, >= 0.
    """
    dy = py - sy
    if abs(dy) >= half:
        return 0.0
    dx = px - sx
    return max(slant_rate(dx * dx + dy * dy, h2, peak_rate, decay), 0.0)


# ----------------------------------------------------------------------------- sums


@njit(cache=True, nogil=True, error_model="numpy")
def _pairwise_block(a, lo, n):  # pragma: no cover - compiled
    """numpy's float64 sum of a[lo:lo + n] for n <= 128: eight accumulators, then the rest."""
    if n < 8:
        res = 0.0
        for i in range(lo, lo + n):
            res += a[i]
        return res
    r0, r1, r2, r3 = a[lo], a[lo + 1], a[lo + 2], a[lo + 3]
    r4, r5, r6, r7 = a[lo + 4], a[lo + 5], a[lo + 6], a[lo + 7]
    i = 8
    m = n - (n % 8)
    while i < m:
        r0 += a[lo + i]
        r1 += a[lo + i + 1]
        r2 += a[lo + i + 2]
        r3 += a[lo + i + 3]
        r4 += a[lo + i + 4]
        r5 += a[lo + i + 5]
        r6 += a[lo + i + 6]
        r7 += a[lo + i + 7]
        i += 8
    res = ((r0 + r1) + (r2 + r3)) + ((r4 + r5) + (r6 + r7))
    while i < n:
        res += a[lo + i]
        i += 1
    return res


@njit(cache=True, nogil=True, error_model="numpy")
def numpy_sum(a, lo, n):  # pragma: no cover - compiled
    """numpy's float64 sum of a[lo:lo + n], for compiled kernels that must give what a numpy
    twin gives: the same bits as ``a[lo:lo + n].sum()`` and as a row of ``A.sum(axis=1)`` for
    a C-contiguous A (tests). O(n).

    The algorithm is numpy's pairwise summation (`pairwise_sum` in numpy's
    ``_core/src/umath/loops_utils.h.src``: blocks of at most 128 summed with eight
    accumulators, halves of a multiple of 8 above); its recursion is walked with an explicit
    stack, since numba's disk cache does not load a recursive kernel safely.

    Args:
        a: a 1-D float64 array.
        lo: the first index summed.
        n: how many elements, lo + n <= len(a).

    Returns:
        The sum (float).
    """
    if n <= 128:
        return _pairwise_block(a, lo, n)
    s_lo = np.empty(64, dtype=np.int64)
    s_n = np.empty(64, dtype=np.int64)
    s_state = np.empty(64, dtype=np.int64)  # 0: left half next, 1: right half, 2: add
    vals = np.empty(64)
    top = 1
    s_lo[0], s_n[0], s_state[0] = lo, n, 0
    nv = 0
    while top > 0:
        t = top - 1
        m = s_n[t]
        if m <= 128:
            vals[nv] = _pairwise_block(a, s_lo[t], m)
            nv += 1
            top -= 1
            continue
        n2 = m // 2
        n2 -= n2 % 8
        if s_state[t] == 0:
            s_state[t] = 1
            s_lo[top], s_n[top], s_state[top] = s_lo[t], n2, 0
            top += 1
        elif s_state[t] == 1:
            s_state[t] = 2
            s_lo[top], s_n[top], s_state[top] = s_lo[t] + n2, m - n2, 0
            top += 1
        else:
            vals[nv - 2] = vals[nv - 2] + vals[nv - 1]
            nv -= 1
            top -= 1
    return vals[0]


# ----------------------------------------------------------------------------- constraints, score


def collision_penalty(l_vio: np.ndarray, mu: float, nu: float) -> np.ndarray:
    """The collision violation V_C5 = mu + nu * L_vio (paper Eq. 6, Sec. 4.1), 0 where L_vio
    is at most `L_VIO_TOL` (the paper: L_vio = 0).

    Args:
        l_vio: the path's length inside obstacles L_vio (m, Eq. 2), any shape.
        mu: the offset mu (`objective.collision_offset`, phi's units).
        nu: the weight nu (`objective.collision_weight`, phi's units per m).

    Returns:
        V_C5 (phi's units), l_vio's shape.
    """
    return np.where(l_vio > L_VIO_TOL, mu + nu * l_vio, 0.0)


def penalised_score(f: np.ndarray | float, phi: np.ndarray | float) -> np.ndarray | float:
    """The penalised score f + delta * phi with delta = `PENALTY_FACTOR` (10), the single
    number the paper ranks optimisers by (Sec. 5.2).

    Args:
        f: objectives (Eq. 3's weighted time, s), a float or an array.
        phi: violations (Eq. 7), a float or an array broadcastable with f.

    Returns:
        The score: a float for floats, else the broadcast array.
    """
    return f + PENALTY_FACTOR * phi


def deb_better(
    f_a: np.ndarray | float, phi_a: np.ndarray | float, f_b: np.ndarray | float,
    phi_b: np.ndarray | float,
) -> np.ndarray | bool:
    """Deb's feasibility rule (paper Eq. 8, Sec. 4.1): a beats b iff phi_a < phi_b, or
    phi_a == phi_b and f_a < f_b.

    Args:
        f_a, phi_a: a's objective (s) and violation, floats or arrays.
        f_b, phi_b: b's, broadcastable with a's.

    Returns:
        Whether a beats b: a bool for floats, else a bool array of the broadcast shape.
    """
    return (phi_a < phi_b) | ((phi_a == phi_b) & (f_a < f_b))


def deb_not_worse(f_a: Any, phi_a: Any, f_b: Any, phi_b: Any) -> Any:
    """Deb's rule (Eq. 8) with ties kept: a is at least as good as b (phi_a < phi_b, or
    phi_a == phi_b and f_a <= f_b).

    Args:
        f_a, phi_a: a's objective (s) and violation, floats or arrays.
        f_b, phi_b: b's, broadcastable with a's.

    Returns:
        Whether a is not worse than b: a bool for floats, else a bool array.
    """
    return (phi_a < phi_b) | ((phi_a == phi_b) & (f_a <= f_b))


def deb_order(f: np.ndarray, phi: np.ndarray) -> np.ndarray:
    """The order of Deb's ranking (Eq. 8): smaller phi first, ties broken by smaller f, full
    ties in index order (stable).

    Args:
        f: objectives (s), shape (n,).
        phi: violations, shape (n,).

    Returns:
        Indices (n,) int, best first.
    """
    return np.lexsort((f, phi))


def deb_best(f: np.ndarray, phi: np.ndarray) -> int:
    """The Deb-best individual (Eq. 8): lowest phi, then lowest f, the first index on full ties.

    Args:
        f: objectives (s), shape (n,).
        phi: violations, shape (n,), without NaN.

    Returns:
        Its index.

    Raises:
        ValueError: n = 0 (or a NaN in phi, which no phi equals).
    """
    cand = np.flatnonzero(phi == phi.min())
    return int(cand[np.argmin(f[cand])])


# ----------------------------------------------------------------------------- parameters


def _points(a: Any) -> np.ndarray:
    return np.ascontiguousarray(np.asarray(a, dtype=float).reshape(-1, 2))


@dataclass(frozen=True, eq=False)
class ModelParams:
    """The model's parameters for one map (paper Table 1 symbols in brackets), read-only.

    UAV: `altitude` [H] m, `v_max` m/s, `accel` [a] m/s^2, `t_max` [T_max] s, `tau` activation
    threshold, `n_points` [I_max]. Radio: `peak_rate` [R_c] and `bandwidth` [R_lambda] Mbit/s,
    `decay` [xi] Mbit/s per m, `access` ("simultaneous", the paper's C3, or "scheduled").
    Objective: `alpha`, collision penalty `mu` + `nu` * L_vio. Map:
    `width`, `height` m, `start`, `end` (2,), `sensors` (J, 2) m, `required` (J,) Mbit.
    Build with :meth:`from_map` (a loaded map) or :meth:`from_settings` (settings, no map yet).
    """

    altitude: float
    v_max: float
    accel: float
    t_max: float
    tau: float
    n_points: int
    peak_rate: float
    decay: float
    bandwidth: float
    alpha: float
    mu: float
    nu: float
    width: float
    height: float
    start: np.ndarray
    end: np.ndarray
    sensors: np.ndarray
    required: np.ndarray
    #: `radio.access`: "simultaneous" (the paper's C3) or "scheduled" (R_lambda shared by time
    #: slots; `planner_core.model.kernels.scheduled_flow`)
    access: str = "simultaneous"

    def __post_init__(self) -> None:
        for name in ("start", "end", "sensors", "required"):
            a = getattr(self, name)
            a = np.ascontiguousarray(a, dtype=float)
            a.flags.writeable = False
            object.__setattr__(self, name, a)

    @classmethod
    def from_settings(
        cls,
        uav: Any,
        radio: Any,
        objective: Any,
        *,
        width: float = 0.0,
        height: float = 0.0,
        start: Any = (0.0, 0.0),
        end: Any = (0.0, 0.0),
        sensors: Any = (),
        required: Any = (),
        n_points: int | None = None,
    ) -> ModelParams:
        """From the map file's settings and the map's geometry (before a map is loaded).

        Args:
            uav, radio, objective: the map file's `uav`, `radio` and `objective` settings
                (objects with the schema's field names, `planner_core.model.mapio.Uav` etc.).
            width, height: the area (m).
            start, end: the take-off and landing points (m), two numbers each.
            sensors: sensor positions (m), J pairs.
            required: each sensor's required data (Mbit), J numbers.
            n_points: I_max (None: `uav.max_hover_points`, 0 when that is None).

        Returns:
            The parameters.

        Raises:
            ValueError: `start` or `end` not two numbers, `sensors` not pairs (numpy's
                message), or a setting a string that is not a number.
            TypeError: a setting that is None or of another type.
        """
        return cls(
            altitude=float(uav.altitude),
            v_max=float(uav.max_speed),
            accel=float(uav.acceleration),
            t_max=float(uav.max_hover_time),
            tau=float(uav.activation_threshold),
            n_points=int(n_points if n_points is not None else (uav.max_hover_points or 0)),
            peak_rate=float(radio.peak_rate),
            decay=float(radio.decay),
            bandwidth=float(radio.bandwidth),
            alpha=float(objective.alpha),
            mu=float(objective.collision_offset),
            nu=float(objective.collision_weight),
            width=float(width),
            height=float(height),
            start=np.asarray(start, dtype=float).reshape(2),
            end=np.asarray(end, dtype=float).reshape(2),
            sensors=_points(sensors),
            required=np.asarray(required, dtype=float).reshape(-1),
            access=str(getattr(radio, "access", "simultaneous")),
        )

    @classmethod
    def from_map(cls, m: Any) -> ModelParams:
        """From a loaded map.

        Args:
            m: a `planner_core.model.mapio.Map` (read: `spec`, `width`, `height`, `start`,
                `end`, `sensors`, `required_data`, `max_hover_points`).

        Returns:
            The parameters.
        """
        spec = m.spec
        return cls.from_settings(
            spec.uav, spec.radio, spec.objective, width=m.width, height=m.height,
            start=m.start, end=m.end, sensors=m.sensors, required=m.required_data,
            n_points=m.max_hover_points,
        )  # fmt: skip

    @property
    def c3_limit(self) -> float:
        """The summed link rate C3 allows at a hover point: R_lambda (`bandwidth`) in
        simultaneous access (the paper's C3), inf in scheduled access (`access`: the sensors
        share R_lambda by time slots, so no C3; what a point collects is bounded in the
        evaluation's `scheduled_flow` and the scheduled hover-time LP instead). The local
        search's C3 screens (`planner_core.search.trial`) compare against it.

        Returns:
            Mbit/s (math.inf in scheduled access).
        """
        return math.inf if self.access == "scheduled" else self.bandwidth

    @cached_property
    def window(self) -> SensorWindow:
        """This map's sensors sorted by x with the radio's range cut (`sensor_window`): the
        compiled rate loops visit only the sensors in range of a point.

        Returns:
            The `SensorWindow` (built once, then kept).
        """
        return sensor_window(self.sensors, self.altitude, self.peak_rate, self.decay)

    def rates(self, pts: np.ndarray, sensors: np.ndarray | None = None) -> np.ndarray:
        """`link_rates` (Sec. 3.1) under this radio; this map's sensors take the range cut
        (`window`): O(I x sensors in range).

        Args:
            pts: hover points (m), shape (..., I, 2).
            sensors: other sensor positions (m), (J, 2) (None: this map's).

        Returns:
            R (Mbit/s, >= 0), shape (..., I, J).
        """
        if sensors is None:
            return link_rates(pts, self.sensors, self.altitude, self.peak_rate, self.decay,
                              self.window)
        return link_rates(pts, sensors, self.altitude, self.peak_rate, self.decay)

    def flight_time(self, d: np.ndarray) -> np.ndarray:
        """`flight_time` (Eq. 1) with this UAV's v_max and a.

        Args:
            d: leg lengths (m), any shape.

        Returns:
            T_fly (s), d's shape.
        """
        return flight_time(d, self.v_max, self.accel)
