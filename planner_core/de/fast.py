"""Compiled trial generation: mutation, crossover and clamping in one pass (numba).

`ask` calls `trials` with the same random draws the numpy operators take; the result is the
same array bit for bit as `clip(crossover(x, mutate(...)), 0, 1)` from `operators.py`, which
stays as the readable, hand-tested reference (a test holds the two together). One pass over
the population instead of a dozen numpy temporaries keeps the optimiser's own time per
generation small next to the problem's evaluation.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from planner_core.de.operators import _TERMS

__all__ = ["draw_donors", "trials"]


@njit(cache=True, fastmath=False)
def _trials(X, mutation, F, best, donors, terms, crossover, Cr, u, j, out):  # pragma: no cover
    m, d = out.shape
    cand = np.empty(7, dtype=np.intp)
    for i in range(m):
        cand[0] = i
        cand[1] = best
        for r in range(5):
            cand[2 + r] = donors[i, r]
        t = terms[mutation[i]]
        a, b, c, p, q = cand[t[0]], cand[t[1]], cand[t[2]], cand[t[3]], cand[t[4]]
        f = F[i]
        cr = Cr[i]
        start = j[i]
        run = d
        if crossover[i] == 1:  # exponential: 1 + leading uniforms below Cr, at most d
            run = 1
            while run < d and u[i, run - 1] < cr:
                run += 1
        expo = crossover[i] == 1
        for k in range(d):
            take = ((k - start) % d) < run if expo else (u[i, k] < cr or k == start)
            v = X[i, k]
            if take:
                v = X[a, k] + f * (X[b, k] - X[c, k]) + f * (X[p, k] - X[q, k])
            out[i, k] = min(max(v, 0.0), 1.0)


def trials(
    X: np.ndarray,
    mutation: np.ndarray,
    F: np.ndarray,
    best: int,
    donors: np.ndarray,
    crossover: np.ndarray,
    Cr: np.ndarray,
    u: np.ndarray,
    j: np.ndarray,
) -> np.ndarray:
    """Clamped trials (m, d) for rows 0..m-1 of X: the operators of `operators.py`, fused."""
    m = len(mutation)
    out = np.empty((m, X.shape[1]))
    _trials(
        np.ascontiguousarray(X, dtype=float), np.asarray(mutation, dtype=np.intp),
        np.asarray(F, dtype=float), int(best), np.asarray(donors, dtype=np.intp), _TERMS,
        np.asarray(crossover, dtype=np.intp), np.asarray(Cr, dtype=float),
        np.ascontiguousarray(u, dtype=float), np.asarray(j, dtype=np.intp), out,
    )  # fmt: skip
    return out


@njit(cache=True, fastmath=False)
def _map_donors(raw, out):  # pragma: no cover
    rows, k = raw.shape
    taken = np.empty(k + 1, dtype=np.intp)
    for i in range(rows):
        taken[0] = i
        count = 1
        for c in range(k):
            r = raw[i, c]
            for t in range(count):  # walk the sorted exclusions, as operators.draw_donors does
                if r >= taken[t]:
                    r += 1
            out[i, c] = r
            pos = count  # insert r keeping `taken` sorted
            while pos > 0 and taken[pos - 1] > r:
                taken[pos] = taken[pos - 1]
                pos -= 1
            taken[pos] = r
            count += 1


def draw_donors(rng: np.random.Generator, n: int, rows: int, k: int = 5) -> np.ndarray:
    """`operators.draw_donors` with the index mapping compiled: same draws, same result."""
    if n < k + 1:
        raise ValueError(f"population {n} too small for {k} distinct donors (need >= {k + 1})")
    raw = np.empty((rows, k), dtype=np.intp)
    for c in range(k):
        raw[:, c] = rng.integers(0, n - 1 - c, size=rows)
    out = np.empty((rows, k), dtype=np.intp)
    _map_donors(raw, out)
    return out
