"""Compiled trial generation (numba): donors, mutation, crossover and clamping in one pass.

`ask` splits one block of raw random words exactly as `operators.draw_donors` and
`operators.draw_crossover` do, and returns bit for bit `clip(crossover(x, mutate(...)), 0, 1)`
from `operators.py`, which stays as the readable, hand-tested reference (tests hold the two
together). One pass over the population instead of a dozen numpy temporaries keeps the
optimiser's own time per generation small next to the problem's evaluation.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from planner_core.search.de.operators import (
    _LOW32,
    _SHIFT32,
    _SHIFT53,
    _TERMS,
    _TWO_M32,
    _TWO_M53,
    N_CROSSOVERS,
    N_DONORS,
    N_MUTATIONS,
    crossover_words,
    donor_words,
)

__all__ = ["ask"]


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


@njit(cache=True, fastmath=False)
def _below(word, m):  # pragma: no cover
    """operators.below(unit_doubles(word), m) for one word."""
    r = int(np.float64(np.int64(word >> _SHIFT53)) * _TWO_M53 * m)
    return min(r, m - 1)


@njit(cache=True, fastmath=False)
def _ask(  # pragma: no cover
    X, mutation, F, best, terms, crossover, Cr, words, out, lower, span, points
):
    m, d = out.shape
    n = X.shape[0]
    k = N_DONORS  # a global: a compile-time constant for numba
    # check the configuration (a status code for the caller to raise on), clip F and Cr
    Fc = np.empty(m)
    Crc = np.empty(m)
    for i in range(m):
        if mutation[i] < 0 or mutation[i] >= terms.shape[0]:
            return 1
        if crossover[i] < 0 or crossover[i] > 1:
            return 2
        if np.isnan(F[i]) or np.isnan(Cr[i]):
            return 3
        Fc[i] = min(max(F[i], 0.0), 1.0)
        Crc[i] = min(max(Cr[i], 0.0), 1.0)
    # split the words as operators.draw_donors, then operators.draw_crossover, do
    ranks = np.empty((m, k), dtype=np.intp)
    p = 0
    for i in range(m):
        for c in range(k):
            ranks[i, c] = _below(words[p], n - 1 - c)
            p += 1
    j = np.empty(m, dtype=np.intp)
    for i in range(m):
        j[i] = _below(words[p], d)
        p += 1
    count = m * d
    flat = np.empty(count)
    pairs = count // 2
    for t in range(pairs):  # high half first; via int64 (exact): cheaper than from uint64
        w = words[p + t]
        flat[2 * t] = np.float64(np.int64(w >> _SHIFT32)) * _TWO_M32
        flat[2 * t + 1] = np.float64(np.int64(w & _LOW32)) * _TWO_M32
    if count % 2:
        flat[count - 1] = np.float64(np.int64(words[p + pairs] >> _SHIFT32)) * _TWO_M32
    u = flat.reshape((m, d))
    donors = np.empty((m, k), dtype=np.intp)
    _map_donors(ranks, donors)
    _trials(X, mutation, Fc, best, donors, terms, crossover, Crc, u, j, out)
    if points.shape[0] == m:  # also map to the problem's box: core.to_problem, same arithmetic
        for i in range(m):
            for c in range(d):
                points[i, c] = out[i, c] * span[c] + lower[c]
    return 0


_ASK_ERRORS = {
    1: f"mutation ids must lie in 0..{N_MUTATIONS - 1}",
    2: f"crossover ids must lie in 0..{N_CROSSOVERS - 1}",
    3: "F and Cr must be numbers in [0, 1] (got NaN)",
}


def ask(
    words: np.ndarray,
    X: np.ndarray,
    mutation: np.ndarray,
    F: np.ndarray,
    best: int,
    crossover: np.ndarray,
    Cr: np.ndarray,
    bounds: tuple[np.ndarray, np.ndarray] | None = None,
) -> np.ndarray | tuple[np.ndarray, np.ndarray]:
    """Clamped trials (m, d) for rows 0..m-1 of X (m = len(mutation)) from raw random ``words``.

    Bit for bit what the numpy operators give when they draw the same words: donors from
    `operators.draw_donors`, then `operators.draw_crossover`, then `mutate`, `crossover` and
    clipping to [0, 1]. F and Cr are clipped to [0, 1].

    Args:
        words: ``donor_words(m) + crossover_words(m, d)`` raw uint64s.
        X: the population (n, d), unit box.
        mutation: operator ids (m,), 0..6.
        F: scale factors (m,).
        best: the Deb-best row of X.
        crossover: crossover ids (m,), 0 bin / 1 exp.
        Cr: crossover rates (m,).
        bounds: ``(lower, span)`` (d,) each, or None.

    Returns:
        The trials (m, d) in [0, 1]; with ``bounds``, ``(trials, lower + trials * span)``,
        the second equal to `core.to_problem` of the first, computed in the same pass.

    Raises:
        ValueError: n < 6 (five distinct donors), ``words`` of another length, operator ids
            out of range or NaN rates.
    """
    n, d = X.shape
    if n < N_DONORS + 1:
        raise ValueError(f"population {n} too small for {N_DONORS} distinct donors")
    m = len(mutation)
    words = np.asarray(words, dtype=np.uint64)
    if words.shape != (donor_words(m) + crossover_words(m, d),):
        raise ValueError(f"ask needs {donor_words(m) + crossover_words(m, d)} raw words")
    out = np.empty((m, d))
    if bounds is None:
        lower = span = np.zeros(d)
        points = np.empty((0, d))
    else:
        lower, span = (np.asarray(b, dtype=float) for b in bounds)
        points = np.empty((m, d))
    status = _ask(
        np.ascontiguousarray(X, dtype=float), np.asarray(mutation, dtype=np.intp),
        np.asarray(F, dtype=float), int(best), _TERMS, np.asarray(crossover, dtype=np.intp),
        np.asarray(Cr, dtype=float), words, out, lower, span, points,
    )  # fmt: skip
    if status:
        raise ValueError(_ASK_ERRORS[status])
    return out if bounds is None else (out, points)
