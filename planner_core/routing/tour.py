"""An open tour through points with fixed ends: nearest neighbour, then 2-opt."""

from __future__ import annotations

import numpy as np
from numba import njit

__all__ = ["open_tour"]

#: a 2-opt move must shorten the tour by more than this (same unit as the weights)
_MIN_GAIN = 1e-6


@njit(cache=True, nogil=True)
def _reverse(t, lo, hi):  # pragma: no cover - compiled
    while lo < hi:
        tmp = t[lo]
        t[lo] = t[hi]
        t[hi] = tmp
        lo += 1
        hi -= 1


@njit(cache=True, nogil=True)
def open_tour(W: np.ndarray, first_improvement: bool = False) -> np.ndarray:  # pragma: no cover
    """Order (P,) of points 0..P-1 from 0 to P-1 (both fixed) for weights W (P, P).

    Nearest neighbour from 0 (ties: lowest index), then 2-opt: reversing t[i+1..j] when that
    shortens the path by more than 1e-6. Best-move 2-opt (the largest gain each round, at most
    8 P rounds) by default; `first_improvement` applies every improving move as the sweep finds
    it and sweeps until none is left.
    """
    P = W.shape[0]
    t = np.empty(P, dtype=np.int64)
    left = np.ones(P, dtype=np.bool_)
    t[0] = 0
    left[0] = False
    left[P - 1] = False
    for s in range(1, P - 1):
        best = -1
        for c in range(P):
            if left[c] and (best < 0 or W[t[s - 1], c] < W[t[s - 1], best]):
                best = c
        t[s] = best
        left[best] = False
    t[P - 1] = P - 1
    rounds = 0
    while first_improvement or rounds < 8 * P:
        rounds += 1
        bi = -1
        bj = -1
        gbest = _MIN_GAIN
        for i in range(P - 2):
            for j in range(i + 1, P - 1):
                g = W[t[i], t[i + 1]] + W[t[j], t[j + 1]] - W[t[i], t[j]] - W[t[i + 1], t[j + 1]]
                if g > gbest:
                    if first_improvement:
                        _reverse(t, i + 1, j)
                        bi = i
                    else:
                        gbest = g
                        bi = i
                        bj = j
        if bi < 0:
            break
        if not first_improvement:
            _reverse(t, bi + 1, bj)
    return t
