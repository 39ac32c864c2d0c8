"""An open tour through points with fixed ends: nearest neighbour, then 2-opt (`open_tour`, the
seeder's); two starts improved by 2-opt and Or-opt (`open_path`, the constructive starts')."""

from __future__ import annotations

import numpy as np
from numba import njit

__all__ = ["KICKS", "open_path", "open_tour", "path_cost"]

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
    8 P rounds) by default.

    Args:
        W: (P, P) weights (e.g. metres or seconds), P >= 1.
        first_improvement: apply every improving move as the sweep finds it and sweep until
            none is left (False: best-move 2-opt).

    Returns:
        (P,) int64 order, t[0] = 0 and t[P - 1] = P - 1.
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
    if not first_improvement:
        _two_opt(W, t)
        return t
    improved = True
    while improved:
        improved = False
        for i in range(P - 2):
            for j in range(i + 1, P - 1):
                g = W[t[i], t[i + 1]] + W[t[j], t[j + 1]] - W[t[i], t[j]] - W[t[i + 1], t[j + 1]]
                if g > _MIN_GAIN:
                    _reverse(t, i + 1, j)
                    improved = True
    return t


@njit(cache=True, nogil=True)
def path_cost(W: np.ndarray, t: np.ndarray) -> float:  # pragma: no cover - compiled
    """Length of the path t (P,) under weights W (P, P): sum of W[t[i], t[i + 1]].

    Args:
        W: (P, P) weights.
        t: (P,) the order, node indices.

    Returns:
        The sum, in W's unit (0.0 for fewer than 2 nodes).
    """
    s = 0.0
    for i in range(t.shape[0] - 1):
        s += W[t[i], t[i + 1]]
    return s


@njit(cache=True, nogil=True)
def _cheapest_insertion(W):  # pragma: no cover - compiled
    """Open path 0 -> ... -> P-1 built by cheapest insertion: start with the two ends, then
    repeatedly insert the point (lowest index on ties) where it adds least."""
    P = W.shape[0]
    t = np.empty(P, dtype=np.int64)
    t[0] = 0
    t[1] = P - 1
    size = 2
    left = np.ones(P, dtype=np.bool_)
    left[0] = False
    left[P - 1] = False
    for _ in range(P - 2):
        bc = -1
        bp = -1
        badd = np.inf
        for c in range(P):
            if not left[c]:
                continue
            for p in range(size - 1):
                add = W[t[p], c] + W[c, t[p + 1]] - W[t[p], t[p + 1]]
                if add < badd:
                    badd = add
                    bc = c
                    bp = p
        for q in range(size, bp + 1, -1):
            t[q] = t[q - 1]
        t[bp + 1] = bc
        left[bc] = False
        size += 1
    return t


@njit(cache=True, nogil=True)
def _two_opt(W, t):  # pragma: no cover - compiled
    """Best-move 2-opt on the open path t (ends fixed) until no reversal gains > _MIN_GAIN."""
    P = t.shape[0]
    for _ in range(8 * P):
        bi = -1
        bj = -1
        gbest = _MIN_GAIN
        for i in range(P - 2):
            for j in range(i + 1, P - 1):
                g = W[t[i], t[i + 1]] + W[t[j], t[j + 1]] - W[t[i], t[j]] - W[t[i + 1], t[j + 1]]
                if g > gbest:
                    gbest = g
                    bi = i
                    bj = j
        if bi < 0:
            return
        _reverse(t, bi + 1, bj)


@njit(cache=True, nogil=True)
def _or_opt(W, t):  # pragma: no cover - compiled
    """One best Or-opt move on the open path t (ends fixed): a run of 1-3 interior points moved
    between two other neighbours, forwards or reversed, when that gains > _MIN_GAIN. Returns
    (the new path, whether a move was made)."""
    P = t.shape[0]
    best = _MIN_GAIN
    bi = -1
    bL = 0
    bk = -1
    brev = False
    for L in range(1, 4):
        for i in range(1, P - L):
            j = i + L - 1  # the run is t[i..j]; t[i-1] and t[j+1] exist
            a = t[i - 1]
            b = t[j + 1]
            s = t[i]
            e = t[j]
            removed = W[a, s] + W[e, b] - W[a, b]
            for k in range(P - 1):
                if i - 1 <= k <= j:
                    continue  # the edge (t[k], t[k+1]) must lie outside the run and its ends
                u = t[k]
                v = t[k + 1]
                fwd = W[u, s] + W[e, v] - W[u, v]
                rev = W[u, e] + W[s, v] - W[u, v]
                if removed - fwd > best:
                    best = removed - fwd
                    bi, bL, bk, brev = i, L, k, False
                if removed - rev > best:
                    best = removed - rev
                    bi, bL, bk, brev = i, L, k, True
    if bi < 0:
        return t, False
    out = np.empty(P, dtype=np.int64)
    run = t[bi : bi + bL].copy()
    if brev:
        run = run[::-1].copy()
    n = 0
    for k in range(P):
        if bi <= k < bi + bL:
            continue
        out[n] = t[k]
        n += 1
        if k == bk:
            for q in range(bL):
                out[n] = run[q]
                n += 1
    return out, True


@njit(cache=True, nogil=True)
def _improve(W, t):  # pragma: no cover - compiled
    """2-opt to its local optimum, then one Or-opt move, until neither gains."""
    for _ in range(64 * t.shape[0]):
        _two_opt(W, t)
        t, moved = _or_opt(W, t)
        if not moved:
            break
    return t


#: double-bridge kicks of `open_path`'s iterated local search
KICKS = 32


@njit(cache=True, nogil=True)
def _double_bridge(t, a, b, c):  # pragma: no cover - compiled
    """t with its interior cut at 0 < a < b < c < P into A B C D and rejoined as A C B D (the
    ends stay: t[0] is in A, t[P-1] in D)."""
    out = np.empty_like(t)
    n = 0
    for k in range(a):
        out[n] = t[k]
        n += 1
    for k in range(b, c):
        out[n] = t[k]
        n += 1
    for k in range(a, b):
        out[n] = t[k]
        n += 1
    for k in range(c, t.shape[0]):
        out[n] = t[k]
        n += 1
    return out


@njit(cache=True, nogil=True)
def open_path(W: np.ndarray, kicks: int = KICKS) -> np.ndarray:  # pragma: no cover - compiled
    """Order (P,) of points 0..P-1 from 0 to P-1 (both fixed) for weights W (P, P), e.g. the
    Eq. 1 flight times of obstacle-aware legs: two starts (nearest neighbour from 0, cheapest
    insertion), each improved by best-move 2-opt and Or-opt (runs of 1-3 points moved, forwards
    or reversed) until neither gains more than 1e-6, the shorter kept (the nearest-neighbour one
    on a tie); then an iterated local search (Lourenco, Martin & Stuetzle 2003): `kicks` times a
    double-bridge move on the best path (cut points from a fixed-seed generator), improved
    again, kept when shorter. Deterministic. 2-opt assumes W symmetric (a reversed run costs
    what it did).

    Args:
        W: (P, P) symmetric weights (e.g. seconds).
        kicks: double-bridge kicks of the iterated local search (`KICKS`); none below 6
            points.

    Returns:
        (P,) int order, first 0 and last P - 1 (0..P-1 unchanged for P <= 3).
    """
    P = W.shape[0]
    if P <= 3:
        return np.arange(P)
    a = _improve(W, open_tour(W))
    b = _improve(W, _cheapest_insertion(W))
    best = b if path_cost(W, b) < path_cost(W, a) - _MIN_GAIN else a
    cost = path_cost(W, best)
    if P < 6:
        return best
    state = np.uint64(0x9E3779B97F4A7C15)  # splitmix64: the same cuts on every platform
    for _ in range(kicks):
        cuts = np.empty(3, dtype=np.int64)
        for q in range(3):
            state += np.uint64(0x9E3779B97F4A7C15)
            z = state
            z = (z ^ (z >> np.uint64(30))) * np.uint64(0xBF58476D1CE4E5B9)
            z = (z ^ (z >> np.uint64(27))) * np.uint64(0x94D049BB133111EB)
            z = z ^ (z >> np.uint64(31))
            cuts[q] = 1 + np.int64(z % np.uint64(P - 2))  # in 1 .. P-2
        cuts.sort()
        if cuts[0] == cuts[1] or cuts[1] == cuts[2]:
            continue
        cand = _improve(W, _double_bridge(best, cuts[0], cuts[1], cuts[2]))
        c = path_cost(W, cand)
        if c < cost - _MIN_GAIN:
            best = cand
            cost = c
    return best
