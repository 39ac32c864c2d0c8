"""The hover-time LP, once: for fixed hover points, the least total hover time meeting C4.

    minimise sum_i T_i   s.t.  sum_i R_ij T_i >= Q_j (every sensor j that needs data),
                               0 <= T_i <= T_max
(the paper's Q_j = sum_i R_ij T_hov,i of Sec. 3 and C2, C4; the rates R_ij fixed by the points).
`hover_lp` solves it by blocks (small ones in a compiled kernel, the rest by a compiled simplex,
HiGHS where a T_max bound binds); the
polish (`planner_core.search.polish`), the descent, the structural moves and the feasibility
diagnosis (`planner_core.model.diagnose`) all take it from here. Units: s, Mbit, Mbit/s.
"""

from __future__ import annotations

import math
import os
import sys
import threading
from collections.abc import Callable
from typing import Any

import numpy as np
from numba import njit

__all__ = ["BLOCK_COMBOS", "BLOCK_VERTICES", "TARGET", "hover_lp", "hover_lp_sparse",
           "quiet_highs", "top_up"]

#: the coverage rows' right-hand side (each sensor's data scaled to 1): a hair above the
#: requirement, so solver tolerance cannot leave a tiny shortfall
TARGET = 1.0 + 1e-9
_TARGET = TARGET

_HIGHS = threading.local()


def _highs() -> Any:
    """This thread's HiGHS solver (highspy), made quiet. highspy prints a banner to file
    descriptor 1 when a process constructs its first solver, so fd 1 points at the null
    device for that moment (the planner's stdout may be a mission file)."""
    h = getattr(_HIGHS, "solver", None)
    if h is None:
        import highspy

        try:
            if sys.stdout is not None:
                sys.stdout.flush()
            saved = os.dup(1)
        except (OSError, ValueError):  # no stdout (closed fd 1, sys.stdout None): nothing to hide
            h = highspy.Highs()
        else:
            null = os.open(os.devnull, os.O_WRONLY)
            try:
                os.dup2(null, 1)
                h = highspy.Highs()
            finally:
                os.dup2(saved, 1)
                os.close(saved)
                os.close(null)
        h.setOptionValue("output_flag", False)
        _HIGHS.solver = h
    return h


def quiet_highs() -> None:
    """Make this process's first HiGHS solver the quiet one (`_highs`), so that a solver made
    later by another interface (cvxpy's HIGHS, which `planner_core.model.bounds` uses) prints no
    banner ("Running HiGHS ... Copyright"): highspy prints it when a process constructs its
    first solver. Costs one solver's construction, once per thread.
    """
    _highs()


#: blocks of the hover-time LP with at most this many points, and at most `BLOCK_COMBOS` sets
#: of constraints to try as a vertex, are solved by enumerating their vertices (`_lp_blocks`);
#: the others by the compiled simplex (`_rest_simplex`), HiGHS where a T_max bound binds
#: (with the final stage's second structure, 3 -> 4 -> 5 points took T16's warm plan() from
#: 0.97 to 0.85 to 0.82 s when the others went to HiGHS; a block of 3-5 points with many
#: sensors, as on the clustered large maps, has thousands of vertices to try, where the
#: simplex takes a few pivots: 200 measured best on L02, L05 and T16's LPs, docs/scaling.md)
BLOCK_VERTICES = 5
BLOCK_COMBOS = 200


def hover_lp(
    R: np.ndarray, req: np.ndarray, t_max: float, warm: dict[Any, Any] | None = None,
    *, highs: Callable[..., Any] | None = None,
) -> tuple[np.ndarray, float, np.ndarray] | None:
    """The feasible hover-time LP of `_lp_matrices` with its duals, for sensitivity analysis.

    By LP sensitivity (e.g. Bertsimas & Tsitsiklis, Introduction to Linear Optimization,
    Sec. 5.1), dV/dR_ij = -y_j T_i / Q_j at a non-degenerate optimum: what
    `planner_core.search.descent` uses.

    Its matrix (the needed sensors' rows of R^T, each over its Q_j) and work arrays come from
    one compiled call (`_scaled_rows`, O(I J); `scaled_rows_reference` its numpy twin).
    The LP separates into blocks, the connected parts of the graph that joins a point to the
    sensors it reaches (R_ij > 0). `_lp_blocks` (compiled) solves a block of one point (on the
    suite's plans most of them) in closed form, T_i = max_j Q_j / R_ij over its sensors with
    dual 1 / A_ji on the first row that attains it, and a block of up to `BLOCK_VERTICES`
    points by enumerating its vertices (at most `BLOCK_COMBOS` sets of constraints); larger
    blocks (and a small block whose optimum would need more than t_max) go together to a
    compiled simplex (`_rest_simplex`), and to HiGHS through highspy when its vertex needs
    more than t_max somewhere or fails a test. HiGHS's fixed cost (~0.1-0.4 ms a call) is what
    the blocks and the simplex save: the descent solves this LP once per trial. The fast path
    of the polish's LP (`planner_core.search.polish._solve_lp(..., "linprog")`, one LP through
    scipy, is its reference; tests/test_descent.py holds them equal; `_solve_lp(..., "highs")`
    calls it for a feasible LP).

    Args:
        R: (I, J) link rates (Mbit/s) of the hover points to every sensor.
        req: (J,) required data Q_j (Mbit).
        t_max: the most hover time per point, s.
        warm: a dict the caller keeps for one sequence of related solves (a descent): the
            last optimal basis of each shape of HiGHS's part is kept in it and the next solve
            starts from it. Where the LP has several optima the one returned may depend on
            that basis, so a caller that must be reproducible passes a fresh dict per
            sequence (None: a cold start, the same answer whatever was solved before).
        highs: the HiGHS step (default `_highs_lp`; the polish passes its own name for it so
            that a test can count the calls).

    Returns:
        (T (I,) hover times in s, topped up so that C4 holds exactly (`top_up`), V = sum T
        in s, y (J,) >= 0 the duals of the coverage rows (R^T T)_j / Q_j >= 1, zero for
        sensors that need nothing), or None when the LP is infeasible (some sensor not
        served even at T_max everywhere).
    """
    n = R.shape[0]
    y = np.zeros(len(req))
    # rows: sensors that need data, scaled so each needs 1 unit; cols: points (compiled)
    A, need, T, yn, rest = _scaled_rows(np.ascontiguousarray(R, dtype=float),
                                        np.ascontiguousarray(req, dtype=float))
    if not len(need):
        return np.zeros(n), 0.0, y
    if not _lp_blocks(A, _TARGET, float(t_max), BLOCK_VERTICES, BLOCK_COMBOS, T, yn, rest):
        return None  # a sensor no point reaches, or a lone point that needs more than t_max
    if rest.any():
        rows, sub = _rest_block(A, rest)
        t_rest, y_rest = np.empty(sub.shape[1]), np.zeros(sub.shape[0])
        if _rest_simplex(sub, _TARGET, float(t_max), t_rest, y_rest):
            T[rest], yn[rows] = t_rest, y_rest
        else:  # a bound T_max binds, or the simplex's vertex failed a test: HiGHS decides
            sol = (highs or _highs_lp)(sub, _TARGET, t_max, warm)
            if sol is None:
                return None
            T[rest], yn[rows] = sol
    y[need] = yn
    T = top_up(R, req, np.clip(T, 0.0, t_max), t_max)
    return T, float(T.sum()), y


@njit(cache=True, fastmath=False, nogil=True)
def _scaled_rows(R, req):  # pragma: no cover - compiled
    """The LP's matrix and work arrays in one call, for `hover_lp`: A (rows, I) with
    A[r, i] = R[i, j_r] / req[j_r] for the sensors j_r with req > 0 in index order (`need`,
    their indices), and zeroed T (I,), duals (rows,) and the HiGHS mask (I,) bool. R (I, J)
    Mbit/s, req (J,) Mbit. The same divisions as `scaled_rows_reference` (tests), done only
    for the links (R_ij != 0; a zero rate's entry is 0.0), R read along its rows. O(I J)
    reads, a division per link."""
    n, J = R.shape
    m = 0
    row_of = np.full(J, -1, dtype=np.int64)
    for j in range(J):
        if req[j] > 0:
            row_of[j] = m
            m += 1
    need = np.empty(m, dtype=np.int64)
    for j in range(J):
        if row_of[j] >= 0:
            need[row_of[j]] = j
    A = np.zeros((m, n))
    for i in range(n):
        for j in range(J):
            if R[i, j] != 0.0 and row_of[j] >= 0:
                A[row_of[j], i] = R[i, j] / req[j]
    return A, need, np.zeros(n), np.zeros(m), np.zeros(n, dtype=np.bool_)


def scaled_rows_reference(R: np.ndarray, req: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """`_scaled_rows`' A and `need` in numpy: (R[:, req > 0] / req[req > 0]).T (rows, I) and
    the indices of the sensors with req > 0.

    Args:
        R: (I, J) link rates, Mbit/s.
        req: (J,) required data, Mbit.

    Returns:
        (A (rows, I) C-contiguous, 1/s: each needed sensor's rates over its req; need
        (rows,) int sensor indices).
    """
    need = req > 0
    return np.ascontiguousarray((R[:, need] / req[need]).T), np.flatnonzero(need)


#: `_solve_small` solves systems of at most this many unknowns by the reference's loops
_DENSE_SOLVE = 8


@njit(cache=True, fastmath=False, nogil=True)
def _solve_two(M, rhs, out):  # pragma: no cover - compiled
    """`_solve_small_reference` for k = 2 written out: the same operations in the same order
    (the largest entry, the pivot row by |M[1, 0]| > |M[0, 0]|, the singular tests, one
    elimination, the back substitution), without its copies and loops (tests). O(1)."""
    w00, w01, w10, w11 = M[0, 0], M[0, 1], M[1, 0], M[1, 1]
    v0, v1 = rhs[0], rhs[1]
    big = 0.0
    big = max(big, abs(w00))
    big = max(big, abs(w01))
    big = max(big, abs(w10))
    big = max(big, abs(w11))
    if abs(w10) > abs(w00):
        if abs(w10) <= 1e-12 * big:
            return False
        w00, w01, w10, w11 = w10, w11, w00, w01
        v0, v1 = v1, v0
    elif abs(w00) <= 1e-12 * big:
        return False
    f = w10 / w00
    w11 -= f * w01
    v1 -= f * v0
    if abs(w11) <= 1e-12 * big:
        return False
    out[1] = v1 / w11
    s = v0
    s -= w01 * out[1]
    out[0] = s / w00
    return True


@njit(cache=True, fastmath=False, nogil=True)
def _rest_block(A, rest):  # pragma: no cover - compiled
    """The LP's part for the simplex: (rows (m,) bool, the rows of A (m, n) with a positive
    entry in a `rest` (n,) column; sub (rows, cols) the copy of A there, C-contiguous), what
    ``(A[:, rest] > 0).any(axis=1)`` and ``A[np.ix_(rows, rest)]`` give (tests). O(m n)."""
    m, n = A.shape
    cols = np.flatnonzero(rest)
    rows = np.zeros(m, dtype=np.bool_)
    nr = 0
    for j in range(m):
        for c in cols:
            if A[j, c] > 0.0:
                rows[j] = True
                nr += 1
                break
    sub = np.empty((nr, cols.shape[0]))
    r = 0
    for j in range(m):
        if rows[j]:
            for q in range(cols.shape[0]):
                sub[r, q] = A[j, cols[q]]
            r += 1
    return rows, sub


@njit(cache=True, fastmath=False, nogil=True)
def _solve_small(M, rhs, out):  # pragma: no cover - compiled
    """Gaussian elimination with partial pivoting on a copy of M (k, k); out = M^-1 rhs.
    False when M is singular (a pivot below 1e-12 of M's largest entry).

    `_solve_small_reference`'s arithmetic with the zeros skipped: a row whose multiplier is 0,
    the pivot row's zero entries and, in the back substitution, the zero entries of a row. Each
    skipped operation is x - (+-0) with x finite and never -0 (M and rhs hold no -0, and a
    difference is -0 only from -0 - +0), which leaves x's bits as they are, so `out` is the
    reference's to the bit (tests); M or rhs holding a -0 or a non-finite entry, or a
    multiplier or unknown that is not finite, take the reference's full loops. Cost: O(k^2)
    plus O(k x the pivot rows' non-zeros) a column, where the reference is O(k^3): the
    simplex's bases on the large maps (`_rest_simplex`, k 70-90) are mostly unit rows; up to
    `_DENSE_SOLVE` unknowns (the small blocks' vertices) the reference's loops are cheaper."""
    k = M.shape[0]
    if k == 2:  # the small blocks' vertices: most solves
        return _solve_two(M, rhs, out)
    if k <= _DENSE_SOLVE:
        return _solve_small_reference(M, rhs, out)
    for i in range(k):
        if not math.isfinite(rhs[i]) or (rhs[i] == 0.0 and math.copysign(1.0, rhs[i]) < 0.0):
            return _solve_small_reference(M, rhs, out)
        for j in range(k):
            x = M[i, j]
            if not math.isfinite(x) or (x == 0.0 and math.copysign(1.0, x) < 0.0):
                return _solve_small_reference(M, rhs, out)
    W = M.copy()
    v = rhs.copy()
    big = 0.0
    for i in range(k):
        for j in range(k):
            big = max(big, abs(W[i, j]))
    nz = np.empty(k, dtype=np.int64)
    for col in range(k):
        if not _partial_pivot(W, v, col, big):
            return False
        n_nz = 0
        for j in range(col, k):
            if W[col, j] != 0.0:
                nz[n_nz] = j
                n_nz += 1
        for i in range(col + 1, k):
            f = W[i, col] / W[col, col]
            if f == 0.0:
                continue
            if math.isfinite(f):
                for q in range(n_nz):
                    j = nz[q]
                    W[i, j] -= f * W[col, j]
            else:
                for j in range(col, k):
                    W[i, j] -= f * W[col, j]
            v[i] -= f * v[col]
    for i in range(k - 1, -1, -1):
        s = v[i]
        for j in range(i + 1, k):
            w = W[i, j]
            if w != 0.0 or not math.isfinite(out[j]):
                s -= w * out[j]
        out[i] = s / W[i, i]
    return True


@njit(cache=True, fastmath=False, nogil=True, inline="always")
def _partial_pivot(W, v, col, big):  # pragma: no cover - compiled
    """Gaussian elimination's step `col` on W (k, k) and v (k,), in place: the row of the
    largest |W[i, col]| from col down (the first of equals) swapped into row col; False when
    that entry is at most 1e-12 x `big` (M's largest entry: singular). O(k)."""
    k = W.shape[0]
    p = col
    for i in range(col + 1, k):
        if abs(W[i, col]) > abs(W[p, col]):
            p = i
    if abs(W[p, col]) <= 1e-12 * big:
        return False
    if p != col:
        for j in range(k):
            W[col, j], W[p, j] = W[p, j], W[col, j]
        v[col], v[p] = v[p], v[col]
    return True


@njit(cache=True, fastmath=False, nogil=True)
def _solve_small_reference(M, rhs, out):  # pragma: no cover - compiled
    """`_solve_small` with every operation done: Gaussian elimination with partial pivoting
    on a copy of M (k, k), out = M^-1 rhs, False when M is singular (a pivot below 1e-12 of
    M's largest entry). O(k^3)."""
    k = M.shape[0]
    W = M.copy()
    v = rhs.copy()
    big = 0.0
    for i in range(k):
        for j in range(k):
            big = max(big, abs(W[i, j]))
    for col in range(k):
        if not _partial_pivot(W, v, col, big):
            return False
        for i in range(col + 1, k):
            f = W[i, col] / W[col, col]
            for j in range(col, k):
                W[i, j] -= f * W[col, j]
            v[i] -= f * v[col]
    for i in range(k - 1, -1, -1):
        s = v[i]
        for j in range(i + 1, k):
            s -= W[i, j] * out[j]
        out[i] = s / W[i, i]
    return True


@njit(cache=True, fastmath=False, nogil=True)
def _lp_blocks(A, target, t_max, kmax, max_combos, T, y, rest):  # pragma: no cover - compiled
    """The blocks of min sum T s.t. A T >= target, 0 <= T <= t_max (A (rows, I) >= 0): writes
    the hover times T (I,) and row duals y (rows,) of every block of at most `kmax` points and
    marks the points of the others (and of blocks with more than `max_combos` vertices to try)
    in `rest` (I,) for `_rest_simplex` (then HiGHS). A small block's vertices are
    enumerated: every k of its constraints (its rows, T_i >= 0) taken as equalities, the first
    (in lexicographic order) whose T is feasible and whose multipliers z (N_S^T z = 1, the
    constraints written as >=) are >= 0 (the KKT conditions of an optimal vertex); a block
    with no such vertex within rounding, or whose optimum needs more than t_max, goes to
    `rest`. Returns False when a row has no point or a lone point needs more than t_max.

    Cost: one O(rows x I) scan of A (the union-find), then O(rows + I) to list every block's
    points and rows (a counting sort by block), plus the vertex enumeration of the small
    blocks, which solves for the multipliers only at a feasible vertex. The reference
    (`_lp_blocks_reference`) scans all rows x the block's points per block and solves both
    systems at every vertex tried; the same tests in the same order of vertices, so the same
    answer to the bit (tests)."""
    m, n = A.shape
    parent = np.arange(n)
    rfirst = np.empty(m, dtype=np.int64)  # each row's first point
    for j in range(m):  # union-find over the points that share a row
        first = -1
        for i in range(n):
            if A[j, i] > 0.0:
                if first < 0:
                    first = i
                    rfirst[j] = i
                    while parent[first] != first:
                        first = parent[first]
                else:
                    r = i
                    while parent[r] != r:
                        r = parent[r]
                    if r != first:
                        parent[max(r, first)] = min(r, first)
                        first = min(r, first)
        if first < 0:
            return False  # a sensor no point reaches
    for i in range(n):
        r = i
        while parent[r] != r:
            r = parent[r]
        parent[i] = r
    # each block's points and rows, ascending (a stable counting sort by root: a row's points
    # all share its first point's root)
    cstart = np.zeros(n + 1, dtype=np.int64)
    rstart = np.zeros(n + 1, dtype=np.int64)
    for i in range(n):
        cstart[parent[i] + 1] += 1
    for j in range(m):
        rstart[parent[rfirst[j]] + 1] += 1
    for r in range(n):
        cstart[r + 1] += cstart[r]
        rstart[r + 1] += rstart[r]
    all_cols = np.empty(n, dtype=np.int64)
    all_rows = np.empty(m, dtype=np.int64)
    fill = cstart[:n].copy()
    for i in range(n):
        all_cols[fill[parent[i]]] = i
        fill[parent[i]] += 1
    fill = rstart[:n].copy()
    for j in range(m):
        r = parent[rfirst[j]]
        all_rows[fill[r]] = j
        fill[r] += 1
    for root in range(n):
        k = cstart[root + 1] - cstart[root]
        if k == 0:
            continue
        cols = all_cols[cstart[root]:cstart[root + 1]]
        rows = all_rows[rstart[root]:rstart[root + 1]]
        nr = rows.shape[0]
        if k == 1:
            i = cols[0]
            best, jb = 0.0, -1
            for q in range(nr):
                t = target / A[rows[q], i]
                if t > best:
                    best, jb = t, rows[q]
            if best > t_max:
                return False
            T[i] = best
            if jb >= 0:
                y[jb] = 1.0 / A[jb, i]
            continue
        c = nr + k  # the block's constraints: its rows, then T_q >= 0
        combos = 1.0
        for q in range(k):  # C(c, k): the vertices to try
            combos = combos * (c - q) / (q + 1)
        if k > kmax or combos > max_combos:
            for q in range(k):
                rest[cols[q]] = True
            continue
        # the largest entry of each of the block's constraints (rows; a bound's is 1) and of
        # each of its points: the tolerances below are relative to them (unit-free)
        cmax = np.ones(c)
        tmax_a = np.zeros(k)
        for q in range(nr):
            m_row = 0.0
            for a in range(k):
                v = A[rows[q], cols[a]]
                m_row = max(m_row, v)
                tmax_a[a] = max(tmax_a[a], v)
            cmax[q] = m_row
        idx = np.arange(k)
        M = np.empty((k, k))
        Mt = np.empty((k, k))
        b = np.empty(k)
        ones = np.ones(k)
        t = np.empty(k)
        z = np.empty(k)
        found = False
        while True:
            for a in range(k):
                s = idx[a]
                for q in range(k):
                    M[a, q] = A[rows[s], cols[q]] if s < nr else (1.0 if s - nr == q else 0.0)
                b[a] = target if s < nr else 0.0
            # the same tests as the reference's, cheapest first: the multipliers (a second
            # solve) only for a feasible vertex
            if _solve_small(M, b, t):
                ok = True
                for a in range(k):  # time x data rate
                    if t[a] * tmax_a[a] < -1e-9:
                        ok = False
                        break
                if ok:
                    for q in range(nr):
                        s = 0.0
                        scale = target
                        for a in range(k):
                            s += A[rows[q], cols[a]] * t[a]
                            scale += abs(A[rows[q], cols[a]] * t[a])
                        if s < target - 1e-9 * scale:
                            ok = False
                            break
                if ok:
                    for a in range(k):
                        for q in range(k):
                            Mt[a, q] = M[q, a]
                    ok = _solve_small(Mt, ones, z)
                    if ok:
                        for a in range(k):  # multiplier x its constraint's scale
                            if z[a] * cmax[idx[a]] < -1e-9:
                                ok = False
                                break
                if ok:
                    found = True
                    break
            # next combination of k out of c, lexicographic
            a = k - 1
            while a >= 0 and idx[a] == c - k + a:
                a -= 1
            if a < 0:
                break
            idx[a] += 1
            for q in range(a + 1, k):
                idx[q] = idx[q - 1] + 1
        tmax_ok = True
        if found:
            for a in range(k):
                if t[a] > t_max:
                    tmax_ok = False
        if not found or not tmax_ok:
            for q in range(k):
                rest[cols[q]] = True
            continue
        for a in range(k):
            T[cols[a]] = max(t[a], 0.0)
            s = idx[a]
            if s < nr:
                y[rows[s]] = max(z[a], 0.0)
    return True


@njit(cache=True, fastmath=False, nogil=True)
def _lp_blocks_reference(A, target, t_max, kmax, max_combos, T, y, rest):  # pragma: no cover
    """The slow reference of `_lp_blocks` (tests hold the two equal): the same blocks, the
    same vertices in the same order and the same tests, but each block's points and rows found
    by scanning every (row, point) of the block (O(I^2 + rows x I) in all) and both systems
    solved at every vertex tried."""
    m, n = A.shape
    parent = np.arange(n)
    for j in range(m):  # union-find over the points that share a row
        first = -1
        for i in range(n):
            if A[j, i] > 0.0:
                if first < 0:
                    first = i
                    while parent[first] != first:
                        first = parent[first]
                else:
                    r = i
                    while parent[r] != r:
                        r = parent[r]
                    if r != first:
                        parent[max(r, first)] = min(r, first)
                        first = min(r, first)
        if first < 0:
            return False  # a sensor no point reaches
    for i in range(n):
        r = i
        while parent[r] != r:
            r = parent[r]
        parent[i] = r
    cols = np.empty(n, dtype=np.int64)
    rows = np.empty(m, dtype=np.int64)
    for root in range(n):
        k = 0
        for i in range(n):
            if parent[i] == root:
                cols[k] = i
                k += 1
        if k == 0:
            continue
        nr = 0
        for j in range(m):
            for q in range(k):
                if A[j, cols[q]] > 0.0:
                    rows[nr] = j
                    nr += 1
                    break
        if k == 1:
            i = cols[0]
            best, jb = 0.0, -1
            for q in range(nr):
                t = target / A[rows[q], i]
                if t > best:
                    best, jb = t, rows[q]
            if best > t_max:
                return False
            T[i] = best
            if jb >= 0:
                y[jb] = 1.0 / A[jb, i]
            continue
        c = nr + k  # the block's constraints: its rows, then T_q >= 0
        combos = 1.0
        for q in range(k):  # C(c, k): the vertices to try
            combos = combos * (c - q) / (q + 1)
        if k > kmax or combos > max_combos:
            for q in range(k):
                rest[cols[q]] = True
            continue
        # the largest entry of each of the block's constraints (rows; a bound's is 1) and of
        # each of its points: the tolerances below are relative to them (unit-free)
        cmax = np.ones(c)
        tmax_a = np.zeros(k)
        for q in range(nr):
            m_row = 0.0
            for a in range(k):
                v = A[rows[q], cols[a]]
                m_row = max(m_row, v)
                tmax_a[a] = max(tmax_a[a], v)
            cmax[q] = m_row
        idx = np.arange(k)
        M = np.empty((k, k))
        Mt = np.empty((k, k))
        b = np.empty(k)
        ones = np.ones(k)
        t = np.empty(k)
        z = np.empty(k)
        found = False
        while True:
            for a in range(k):
                s = idx[a]
                for q in range(k):
                    M[a, q] = A[rows[s], cols[q]] if s < nr else (1.0 if s - nr == q else 0.0)
                b[a] = target if s < nr else 0.0
            for a in range(k):
                for q in range(k):
                    Mt[a, q] = M[q, a]
            if _solve_small_reference(M, b, t) and _solve_small_reference(Mt, ones, z):
                ok = True
                for a in range(k):  # multiplier x its constraint's scale; time x data rate
                    if z[a] * cmax[idx[a]] < -1e-9 or t[a] * tmax_a[a] < -1e-9:
                        ok = False
                        break
                if ok:
                    for q in range(nr):
                        s = 0.0
                        scale = target
                        for a in range(k):
                            s += A[rows[q], cols[a]] * t[a]
                            scale += abs(A[rows[q], cols[a]] * t[a])
                        if s < target - 1e-9 * scale:
                            ok = False
                            break
                if ok:
                    found = True
                    break
            # next combination of k out of c, lexicographic
            a = k - 1
            while a >= 0 and idx[a] == c - k + a:
                a -= 1
            if a < 0:
                break
            idx[a] += 1
            for q in range(a + 1, k):
                idx[q] = idx[q - 1] + 1
        tmax_ok = True
        if found:
            for a in range(k):
                if t[a] > t_max:
                    tmax_ok = False
        if not found or not tmax_ok:
            for q in range(k):
                rest[cols[q]] = True
            continue
        for a in range(k):
            T[cols[a]] = max(t[a], 0.0)
            s = idx[a]
            if s < nr:
                y[rows[s]] = max(z[a], 0.0)
    return True


@njit(cache=True, fastmath=False, nogil=True)
def _rest_simplex(A, target, t_max, T, y):  # pragma: no cover - compiled
    """min sum T s.t. A T >= target, T >= 0 (A (rows, k) >= 0, every row with a positive
    entry) by the primal simplex on its dual, max sum w s.t. A^T w <= 1, w >= 0, whose slack
    basis is feasible (Dantzig's rule, then Bland's after 5 (rows + k + 1) pivots, so it ends;
    Chvatal, Linear Programming, 1983, ch. 2-3). The optimal basis names k tight constraints
    of the primal (row j where w_j is basic, T_i >= 0 where slack u_i is), and T and the row
    multipliers are solved from them (`_solve_small`) and put to `_lp_blocks`' own relative
    tests (T >= 0, every row met within 1e-9 of its scale, multipliers >= 0, T <= t_max).
    Writes T (k,) s and y (rows,) and returns True when they pass, else False (then HiGHS
    decides, with the t_max bounds). Cost: O(k (rows + k)) a pivot, a few pivots per
    point in practice, and O(k^3) for the two solves: on the large maps' blocks of 5-11
    points and 6-24 rows ~5 us against HiGHS's ~0.4 ms a call (docs/scaling.md)."""
    m, k = A.shape
    ncol = m + k
    D = np.zeros((k, ncol + 1))
    for i in range(k):
        for j in range(m):
            D[i, j] = A[j, i]
        D[i, m + i] = 1.0
        D[i, ncol] = 1.0
    red = np.zeros(ncol)
    for j in range(m):
        red[j] = -1.0
    basis = np.empty(k, dtype=np.int64)
    for i in range(k):
        basis[i] = m + i
    cap = 50 * (ncol + 1)
    bland_after = 5 * (ncol + 1)
    it = 0
    while True:
        col = -1
        if it < bland_after:
            best = -1e-12
            for j in range(ncol):
                if red[j] < best:
                    best, col = red[j], j
        else:
            for j in range(ncol):
                if red[j] < -1e-12:
                    col = j
                    break
        if col < 0:
            break
        it += 1
        if it > cap:
            return False
        cmax_ = 0.0
        for i in range(k):
            cmax_ = max(cmax_, abs(D[i, col]))
        row = -1
        ratio = np.inf
        for i in range(k):
            if D[i, col] > 1e-12 * cmax_:
                r = D[i, ncol] / D[i, col]
                if r < ratio or (r == ratio and basis[i] < basis[row]):
                    ratio, row = r, i
        if row < 0:
            return False  # unbounded dual: cannot happen with nonzero rows
        p = D[row, col]
        for j in range(ncol + 1):
            D[row, j] /= p
        for i in range(k):
            if i != row:
                f = D[i, col]
                if f != 0.0:
                    for j in range(ncol + 1):
                        D[i, j] -= f * D[row, j]
        f = red[col]
        for j in range(ncol):
            red[j] -= f * D[row, j]
        basis[row] = col
    # the primal vertex of this basis: rows j with w_j basic tight, T_i = 0 for u_i basic
    srt = np.sort(basis)
    M = np.zeros((k, k))
    b = np.zeros(k)
    for a in range(k):
        s = srt[a]
        if s < m:
            for q in range(k):
                M[a, q] = A[s, q]
            b[a] = target
        else:
            M[a, s - m] = 1.0
    t = np.empty(k)
    z = np.empty(k)
    if not _solve_small(M, b, t):
        return False
    Mt = M.T.copy()
    if not _solve_small(Mt, np.ones(k), z):
        return False
    tmax_a = np.zeros(k)
    for j in range(m):
        for q in range(k):
            tmax_a[q] = max(tmax_a[q], A[j, q])
    for a in range(k):
        s = srt[a]
        scale = 1.0
        if s < m:
            scale = 0.0
            for q in range(k):
                scale = max(scale, A[s, q])
        if not z[a] * scale >= -1e-9:  # written so that NaN fails too
            return False
    for q in range(k):
        if not (t[q] * tmax_a[q] >= -1e-9 and t[q] <= t_max):
            return False
    for j in range(m):
        s = 0.0
        sc = target
        for q in range(k):
            s += A[j, q] * t[q]
            sc += abs(A[j, q] * t[q])
        if not s >= target - 1e-9 * sc:
            return False
    for q in range(k):
        T[q] = max(t[q], 0.0)
    for j in range(m):
        y[j] = 0.0
    for a in range(k):
        if srt[a] < m:
            y[srt[a]] = max(z[a], 0.0)
    return True


def _highs_lp(
    A: np.ndarray, target: float, t_max: float, warm: dict[Any, Any] | None
) -> tuple[np.ndarray, np.ndarray] | None:
    """min sum T s.t. A T >= target, 0 <= T <= t_max through HiGHS (highspy): (T (cols,), row
    duals (rows,) >= 0), or None when infeasible. A (rows, cols) >= 0; `warm` as `hover_lp`'s
    (keyed by A's shape)."""
    import highspy

    n = A.shape[1]
    lp = highspy.HighsLp()
    lp.num_col_, lp.num_row_ = n, A.shape[0]
    lp.col_cost_, lp.col_lower_, lp.col_upper_ = np.ones(n), np.zeros(n), np.full(n, t_max)
    lp.row_lower_ = np.full(A.shape[0], target)
    lp.row_upper_ = np.full(A.shape[0], highspy.kHighsInf)
    lp.a_matrix_.format_ = highspy.MatrixFormat.kRowwise
    if isinstance(A, np.ndarray):
        nz = A != 0.0
        lp.a_matrix_.start_ = np.concatenate([[0], np.cumsum(nz.sum(axis=1))]).astype(np.int32)
        lp.a_matrix_.index_ = np.nonzero(nz)[1].astype(np.int32)
        lp.a_matrix_.value_ = A[nz]
    else:  # a scipy sparse matrix (`hover_lp_sparse`)
        csr = A.tocsr()
        lp.a_matrix_.start_ = csr.indptr.astype(np.int32)
        lp.a_matrix_.index_ = csr.indices.astype(np.int32)
        lp.a_matrix_.value_ = csr.data.astype(float)
    solver = _highs()
    solver.passModel(lp)
    basis = warm.get(A.shape) if warm is not None else None
    if basis is not None:
        solver.setBasis(basis)
    solver.run()
    if solver.getModelStatus() != highspy.HighsModelStatus.kOptimal:
        if warm is not None:
            warm.pop(A.shape, None)
        return None
    if warm is not None:
        warm[A.shape] = solver.getBasis()
    sol = solver.getSolution()
    return (np.clip(np.asarray(sol.col_value, dtype=float), 0.0, t_max),
            np.maximum(np.asarray(sol.row_dual, dtype=float), 0.0))


def top_up(R: np.ndarray, req: np.ndarray, times: np.ndarray, t_max: float) -> np.ndarray:
    """Scale hover times (s) up by the worst remaining ratio (tiny) so that Q_j >= req_j
    (Mbit) holds exactly.

    At most 5 rounds; each multiplies by min(ratio (1 + 1e-12), 1 + 1e-6) and adds 1e-12 s,
    so only a tiny shortfall is closed (and t_max may keep one).

    Args:
        R: (I, J) link rates, Mbit/s (dense, or scipy.sparse: only ``R.T @ times`` is used).
        req: (J,) required data, Mbit.
        times: (I,) hover times, s.
        t_max: the most hover time per point, s.

    Returns:
        (I,) hover times, s, at most t_max s each (`times` itself when nothing is short).
    """
    for _ in range(5):
        Q = R.T @ times
        short = (req > 0) & (Q < req)
        if not short.any():
            break
        ratio = float(np.max(req[short] / np.maximum(Q[short], 1e-300)))
        times = np.minimum(times * min(ratio * (1 + 1e-12), 1.0 + 1e-6) + 1e-12, t_max)
    return times


def hover_lp_sparse(
    R: Any, req: np.ndarray, t_max: float
) -> tuple[np.ndarray, float, np.ndarray] | None:
    """`hover_lp` for many points with few links each: R a scipy.sparse (I, J) matrix of link
    rates (Mbit/s), req (J,) Mbit, t_max s (may be inf). The same LP, min sum T s.t.
    (R^T T)_j / Q_j >= 1 for every j with Q_j > 0, 0 <= T <= t_max, solved whole by HiGHS
    without the dense blocks (the feasibility diagnosis states it over thousands of cells).

    Args:
        R: (I, J) link rates, Mbit/s, scipy.sparse (or anything `scipy.sparse.csr_matrix`
            takes).
        req: (J,) required data Q_j, Mbit.
        t_max: the most hover time per point, s (may be inf).

    Returns:
        (T (I,) s, topped up as `hover_lp`'s, V = sum T s, y (J,) >= 0 the coverage rows'
        duals) or None when infeasible (a sensor that needs data and has no link, or HiGHS
        finds no optimum).
    """
    import scipy.sparse as sp

    R = sp.csr_matrix(R, dtype=float)
    need = np.asarray(req) > 0
    n = R.shape[0]
    y = np.zeros(len(req))
    if not need.any():
        return np.zeros(n), 0.0, y
    A = (R[:, np.flatnonzero(need)] @ sp.diags(1.0 / req[need])).T.tocsr()
    A.eliminate_zeros()
    if np.any(np.diff(A.indptr) == 0):
        return None
    sol = _highs_lp(A, _TARGET, float(t_max), None)
    if sol is None:
        return None
    T, y[need] = sol
    T = top_up(R, req, np.clip(T, 0.0, t_max), t_max)  # R.T @ T: sparse works too
    return T, float(T.sum()), y


def _highs_general(
    cost: np.ndarray, col_lo: np.ndarray, col_hi: np.ndarray, A: Any, row_lo: np.ndarray,
    row_hi: np.ndarray,
) -> tuple[np.ndarray, np.ndarray] | None:
    """min cost.x s.t. row_lo <= A x <= row_hi, col_lo <= x <= col_hi through HiGHS (highspy):
    (x, row duals) or None when not solved to optimality. A scipy sparse; inf bounds free."""

    csr = A.tocsr()
    return _highs_arrays(cost, col_lo, col_hi, (csr.shape[0], False, csr.indptr, csr.indices,
                                                csr.data), row_lo, row_hi)


def _highs_arrays(
    cost: np.ndarray, col_lo: np.ndarray, col_hi: np.ndarray, matrix: tuple[Any, ...],
    row_lo: np.ndarray, row_hi: np.ndarray,
) -> tuple[np.ndarray, np.ndarray] | None:
    """`_highs_general` with the matrix as compressed arrays: matrix = (rows, colwise,
    start, index, value), row-wise (CSR) or column-wise (CSC)."""
    import highspy

    n_rows, colwise, start, index, value = matrix
    lp = highspy.HighsLp()
    lp.num_col_, lp.num_row_ = len(cost), int(n_rows)
    inf = highspy.kHighsInf
    lp.col_cost_ = np.asarray(cost, dtype=float)
    lp.col_lower_ = np.where(np.isfinite(col_lo), col_lo, -inf).astype(float)
    lp.col_upper_ = np.where(np.isfinite(col_hi), col_hi, inf).astype(float)
    lp.row_lower_ = np.where(np.isfinite(row_lo), row_lo, -inf).astype(float)
    lp.row_upper_ = np.where(np.isfinite(row_hi), row_hi, inf).astype(float)
    lp.a_matrix_.format_ = (highspy.MatrixFormat.kColwise if colwise
                            else highspy.MatrixFormat.kRowwise)
    lp.a_matrix_.start_ = np.asarray(start).astype(np.int32)
    lp.a_matrix_.index_ = np.asarray(index).astype(np.int32)
    lp.a_matrix_.value_ = np.asarray(value).astype(float)
    solver = _highs()
    solver.passModel(lp)
    # primal simplex: ~4x faster than the default dual on the scheduled LP's many D_ij columns
    # (the diagnosis's cells); the shared solver gets its strategy back for `hover_lp`
    saved = solver.getOptionValue("simplex_strategy")
    saved = saved[1] if isinstance(saved, tuple) else saved  # highspy: (status, value)
    solver.setOptionValue("simplex_strategy", 4)
    try:
        solver.run()
    finally:
        solver.setOptionValue("simplex_strategy", saved)
    if solver.getModelStatus() != highspy.HighsModelStatus.kOptimal:
        return None
    sol = solver.getSolution()
    return np.asarray(sol.col_value, dtype=float), np.asarray(sol.row_dual, dtype=float)


def scheduled_lp(
    R: Any, req: np.ndarray, bandwidth: float, t_max: float
) -> tuple[np.ndarray, Any, float, np.ndarray] | None:
    """The hover-time LP of scheduled access (`radio.access` "scheduled"): the sensors in range
    of a hover point share its bandwidth by time slots, so the data D_ij (Mbit) taken from
    sensor j at point i is a variable:

        minimise sum_i T_i  s.t.  D_ij <= R_ij T_i           (sensor j's link rate)
                                  sum_j D_ij <= R_lambda T_i  (the point's bandwidth)
                                  sum_i D_ij >= Q_j           (C4, every j with Q_j > 0)
                                  0 <= T_i <= T_max, D_ij >= 0.

    With R_lambda >= sum_j R_ij at every point it is `hover_lp`'s LP (D_ij = R_ij T_i). Stated
    in D_ij / Q_j, solved whole by HiGHS (highspy).

    Args:
        R: (I, J) link rates, Mbit/s (numpy or scipy sparse).
        req: (J,) Q_j, Mbit.
        bandwidth: R_lambda, Mbit/s.
        t_max: T_max, s (may be inf).

    Returns:
        (T (I,) s, D (I, J) scipy CSR Mbit, V = sum T s, y (J,) >= 0 the duals of the C4
        rows in D_ij / Q_j units, zero for sensors that need nothing), or None when
        infeasible (a sensor that needs data out of every point's range, or more than T_max
        allows).
    """
    sol = _scheduled_solve(R, req, bandwidth, t_max)
    return None if sol is None else sol[:4]


def scheduled_lp_links(
    R: np.ndarray, req: np.ndarray, bandwidth: float, t_max: float
) -> tuple[np.ndarray, float, np.ndarray] | None:
    """`scheduled_lp` with the sensitivity of its optimum to the link rates, for the local
    search's gradient (`planner_core.search.descent.objective` in scheduled access): the dual
    u_ij <= 0 of the row D_ij / Q_j <= (R_ij / Q_j) T_i gives dV/dR_ij = u_ij T_i / Q_j
    (envelope theorem), returned as L_ij = -u_ij / Q_j >= 0, so that dV/dR_ij = -L_ij T_i:
    the simultaneous LP's y_j / Q_j per pair (`hover_lp`'s duals), zero where the point's
    bandwidth row, not the sensor's link, limits what it takes.

    The LP falls apart into the connected components of the points and the sensors that need
    data linked to them (no row or column joins two): each is solved on its own and kept (per
    thread, the last `SCHEDULED_CACHE_SIZE`, by its rates, data, R_lambda and T_max), so a
    move of one point solves the LPs of the components it touches only (the local search's
    kicks and rebuilds). A component whose points each hear at most R_lambda in all is the
    simultaneous LP (its bandwidth rows cannot bind, so D_ij = R_ij T_i) and is solved by the
    compiled `hover_lp`, its link weights y_j / Q_j on every link. Points in no component
    hover 0 s. Cost: one HiGHS LP per new component past C3 (~0.5-10 ms on the large maps'
    plans), a connected-components pass over the I x J links.

    Args:
        R: (I, J) link rates, Mbit/s (dense).
        req: (J,) Q_j, Mbit.
        bandwidth: R_lambda, Mbit/s.
        t_max: T_max, s (may be inf).

    Returns:
        (T (I,) s, V = sum T s, L (I, J) >= 0 per Mbit/s, dense), or None as `scheduled_lp`.
    """
    R = np.ascontiguousarray(R, dtype=float)
    req = np.asarray(req, dtype=float).reshape(-1)
    n, J = R.shape
    need = req > 0
    pi, pj = np.nonzero((R > 0) & need[None, :])
    linked = np.zeros(J, dtype=bool)
    linked[pj] = True
    if not linked[need].all():
        return None  # a sensor that needs data has no link
    T, L = np.zeros(n), np.zeros((n, J))
    if not len(pi):
        return T, 0.0, L
    if np.isfinite(t_max):
        # a sensor no allocation can fill even at T_max everywhere (each point sends it at
        # most min(R_ij, R_lambda)): the LP is infeasible, no need to build it (most of the
        # rebuild moves' refused draws on clustered fields)
        # (a margin far above HiGHS's feasibility tolerance: only a clear shortfall is cut)
        most = np.minimum(R[:, need], float(bandwidth)).sum(axis=0) * float(t_max)
        if np.any(most < req[need] * (1.0 - 1e-6)):
            return None
    cache = _scheduled_cache()
    for rows, cols in link_components(pi, pj, n, J):
        sub = R[np.ix_(rows, cols)]
        key = (sub.shape, sub.tobytes(), req[cols].tobytes(), float(bandwidth), float(t_max))
        got = cache.pop(key, _UNSOLVED)
        if got is None:  # solved before: infeasible
            cache[key] = None
            return None
        if got is _UNSOLVED and float(sub.sum(axis=1).max()) <= bandwidth:
            # every point of the component hears at most R_lambda in all: the bandwidth rows
            # cannot bind, D_ij = R_ij T_i, and the LP is the simultaneous one (`hover_lp`,
            # compiled) with its link duals y_j / Q_j on every link
            lp = hover_lp(sub, req[cols], t_max)
            if lp is None:
                _remember(cache, key, None)
                return None
            got = (lp[0], np.where(sub > 0, (lp[2] / req[cols])[None, :], 0.0))
        if got is _UNSOLVED:
            core = _scheduled_core(sub, req[cols], bandwidth, t_max)
            if core is None:
                _remember(cache, key, None)
                return None
            t, _, dual, _, (si, sj), _ = core
            w = np.zeros(sub.shape)
            w[si, sj] = np.maximum(-dual, 0.0) / req[cols][sj]
            got = (t, w)
        _remember(cache, key, got)
        T[rows] = got[0]
        L[rows[:, None], cols[None, :]] = got[1]
    return T, float(T.sum()), L


def link_components(pi: np.ndarray, pj: np.ndarray, n: int,
                    J: int) -> list[tuple[np.ndarray, np.ndarray]]:
    """The connected components of the bipartite graph of n points and J sensors joined by
    the links (pi[e], pj[e]): per component its points and its sensors, each ascending, the
    components in the order of their first point (what `scheduled_lp_links` solves one by
    one). Compiled union-find (`_link_labels`); `link_components_reference` is the scipy
    twin. Cost: O(E alpha(E) + n + J) for E links.

    Args:
        pi: (E,) point index of each link (0..n-1).
        pj: (E,) sensor index of each link (0..J-1).
        n: points; J: sensors.

    Returns:
        [(rows (k,) int, cols (m,) int)] per component; points and sensors without a link
        are in none.
    """
    label, k = _link_labels(np.asarray(pi, dtype=np.int64), np.asarray(pj, dtype=np.int64),
                            int(n), int(J))  # fmt: skip
    return _groups(label[:n], label[n:], k)


def _groups(pl: np.ndarray, sl: np.ndarray, k: int) -> list[tuple[np.ndarray, np.ndarray]]:
    """Points and sensors grouped by their component label (-1: none), ascending in each."""
    rows = np.argsort(pl, kind="stable")
    rows = rows[pl[rows] >= 0]
    cols = np.argsort(sl, kind="stable")
    cols = cols[sl[cols] >= 0]
    r_cut = np.cumsum(np.bincount(pl[rows], minlength=k))
    c_cut = np.cumsum(np.bincount(sl[cols], minlength=k))
    return [(rows[(r_cut[c - 1] if c else 0):r_cut[c]], cols[(c_cut[c - 1] if c else 0):c_cut[c]])
            for c in range(k)]


def link_components_reference(pi: np.ndarray, pj: np.ndarray, n: int,
                              J: int) -> list[tuple[np.ndarray, np.ndarray]]:
    """Slow, obviously correct twin of `link_components` (scipy's connected components on the
    (n + J)-node graph; components relabelled in the order of their first point).

    Args:
        pi, pj, n, J: as `link_components`.

    Returns:
        As `link_components`.
    """
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    graph = coo_matrix((np.ones(len(pi)), (pi, n + pj)), shape=(n + J, n + J))
    _, label = connected_components(graph, directed=False)
    used = np.zeros(n + J, dtype=bool)
    used[pi] = True
    used[n + np.asarray(pj)] = True
    first: dict[int, int] = {}
    for node in range(n + J):
        if used[node] and label[node] not in first:
            first[int(label[node])] = len(first)
    lab = np.array([first[int(label[x])] if used[x] else -1 for x in range(n + J)], dtype=int)
    return _groups(lab[:n], lab[n:], len(first))


@njit(cache=True, fastmath=False, nogil=True)
def _link_labels(pi, pj, n, J):  # pragma: no cover - compiled
    """Union-find over the links (node p for point p, n + j for sensor j): each linked node's
    component label, 0.. in the order of the component's lowest node, -1 for a node without a
    link; and the number of components."""
    parent = np.arange(n + J)
    used = np.zeros(n + J, dtype=np.bool_)
    for e in range(len(pi)):
        a = pi[e]
        b = n + pj[e]
        used[a] = True
        used[b] = True
        while parent[a] != a:
            parent[a] = parent[parent[a]]
            a = parent[a]
        while parent[b] != b:
            parent[b] = parent[parent[b]]
            b = parent[b]
        if a < b:
            parent[b] = a
        elif b < a:
            parent[a] = b
    label = np.full(n + J, -1, dtype=np.int64)
    of_root = np.full(n + J, -1, dtype=np.int64)
    k = 0
    for x in range(n + J):
        if not used[x]:
            continue
        r = x
        while parent[r] != r:
            r = parent[r]
        if of_root[r] < 0:
            of_root[r] = k
            k += 1
        label[x] = of_root[r]
    return label, k


#: components `scheduled_lp_links` keeps solved (per thread; an infeasible one as None), the
#: least recently used dropped first
SCHEDULED_CACHE_SIZE = 4096
#: a component `scheduled_lp_links` has not solved yet (its cache holds None for infeasible)
_UNSOLVED: Any = object()


def _remember(cache: dict[tuple[Any, ...], Any], key: tuple[Any, ...], got: Any) -> None:
    """Keep a solved component (None: infeasible) as the most recent, dropping the oldest
    beyond `SCHEDULED_CACHE_SIZE`."""
    cache[key] = got
    while len(cache) > SCHEDULED_CACHE_SIZE:
        del cache[next(iter(cache))]
_SCHEDULED = threading.local()


def _scheduled_cache() -> dict[tuple[Any, ...], tuple[np.ndarray, np.ndarray]]:
    """This thread's solved components (`scheduled_lp_links`), oldest first."""
    cache = getattr(_SCHEDULED, "cache", None)
    if cache is None:
        cache = _SCHEDULED.cache = {}
    return cache


def _scheduled_solve(
    R: Any, req: np.ndarray, bandwidth: float, t_max: float
) -> tuple[np.ndarray, Any, float, np.ndarray, Any] | None:
    """`scheduled_lp`'s solve: its (T, D, V, y) and L (I, J) CSR, `scheduled_lp_links`'s
    link weights."""
    import scipy.sparse as sp

    core = _scheduled_core(R, req, bandwidth, t_max)
    if core is None:
        return None
    T, d, dual_links, y, (pi, pj), (n, J) = core
    req = np.asarray(req, dtype=float).reshape(-1)
    if not len(pi):
        return T, sp.csr_matrix((n, J)), float(T.sum()), y, sp.csr_matrix((n, J))
    D = sp.csr_matrix((np.maximum(d, 0.0) * req[pj], (pi, pj)), shape=(n, J))
    L = sp.csr_matrix((np.maximum(-dual_links, 0.0) / req[pj], (pi, pj)), shape=(n, J))
    return T, D, float(T.sum()), y, L


def _scheduled_core(
    R: Any, req: np.ndarray, bandwidth: float, t_max: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, tuple[np.ndarray, np.ndarray],
           tuple[int, int]] | None:
    """The scheduled LP (`scheduled_lp`'s docstring) over the pairs (i, j) with R_ij > 0 and
    Q_j > 0, in row-major order: (T (I,), d (k,) = D_ij / Q_j, the link rows' duals (k,),
    y (J,), (pi, pj) the pairs' indices, (I, J)), or None when infeasible. R dense (numpy)
    or scipy sparse; the matrix is passed to HiGHS column by column, built here."""
    req = np.asarray(req, dtype=float).reshape(-1)
    if isinstance(R, np.ndarray):
        n, J = R.shape
        pi, pj = np.nonzero((R > 0) & (req > 0)[None, :])
        pr = R[pi, pj]
    else:
        import scipy.sparse as sp

        R = sp.csr_matrix(R, dtype=float)
        n, J = R.shape
        coo = R.tocoo()
        keep = (coo.data > 0) & (req[coo.col] > 0)
        pi, pj, pr = coo.row[keep], coo.col[keep], coo.data[keep]
    y = np.zeros(J)
    empty = np.zeros(0)
    if not np.any(req > 0):
        return np.zeros(n), empty, empty, y, (pi[:0], pj[:0]), (n, J)
    need = np.flatnonzero(req > 0)
    linked = np.zeros(J, dtype=bool)
    linked[pj] = True
    if not linked[need].all():
        return None  # a sensor that needs data has no link
    k = len(pi)
    a = pr / req[pj]  # d_ij = D_ij / Q_j <= a_ij T_i
    # rows 0..k-1: d_k - a_k T_i <= 0; k..k+n-1: sum_j Q_j d_ij - R_lambda T_i <= 0;
    # then one row per sensor that needs data: sum_i d_ij >= 1 (a hair above: `TARGET`).
    # Columns T_0..T_{n-1} (each: its pairs' link rows, then its bandwidth row), then d_r
    # (each: its link row, its point's bandwidth row, its sensor's row); rows ascending.
    row_of = np.full(J, -1)
    row_of[need] = np.arange(len(need))
    per = np.bincount(pi, minlength=n) + 1
    start = np.concatenate([[0], np.cumsum(per), n + k + 3 * np.arange(1, k + 1)])
    index = np.empty(n + k + 3 * k, dtype=np.int64)
    value = np.empty(n + k + 3 * k)
    slot = np.arange(k) + pi  # pair r in T_{pi[r]}'s column: i bandwidth entries before
    index[slot], value[slot] = np.arange(k), -a
    last = start[1:n + 1] - 1
    index[last], value[last] = k + np.arange(n), -float(bandwidth)
    dcols = (n + k + np.arange(3 * k)).reshape(k, 3)
    index[dcols[:, 0]], value[dcols[:, 0]] = np.arange(k), 1.0
    index[dcols[:, 1]], value[dcols[:, 1]] = k + pi, req[pj]
    index[dcols[:, 2]], value[dcols[:, 2]] = k + n + row_of[pj], 1.0
    m = k + n + len(need)
    lo = np.concatenate([np.full(k + n, -np.inf), np.full(len(need), _TARGET)])
    hi = np.concatenate([np.zeros(k + n), np.full(len(need), np.inf)])
    cost = np.concatenate([np.ones(n), np.zeros(k)])
    ub = np.concatenate([np.full(n, float(t_max)), np.full(k, np.inf)])
    sol = _highs_arrays(cost, np.zeros(n + k), ub, (m, True, start, index, value), lo, hi)
    if sol is None:
        return None
    x, dual = sol
    T = np.clip(x[:n], 0.0, t_max)
    y[need] = np.maximum(dual[m - len(need):], 0.0)
    return T, x[n:], dual[:k], y, (pi, pj), (n, J)
