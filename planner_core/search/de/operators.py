"""DE variation operators, vectorised over the population with one operator per individual.

Everything here is pure: randomness enters as explicit arrays (donor indices, uniforms, start
positions) drawn by the ``draw_*`` helpers, so tests can pass hand-picked values.

Mutations (i = current individual, best = Deb-best individual, r1..r5 = donors that are
distinct from each other and from i; ``best`` may coincide with i or a donor):

====  ====================  ==========================================================
 id    name                  mutant v_i
====  ====================  ==========================================================
 0     rand/1                x_r1 + F (x_r2 - x_r3)
 1     best/1                x_best + F (x_r1 - x_r2)
 2     rand/2                x_r1 + F (x_r2 - x_r3) + F (x_r4 - x_r5)
 3     best/2                x_best + F (x_r1 - x_r2) + F (x_r3 - x_r4)
 4     current-to-rand/1     x_i + F (x_r1 - x_i) + F (x_r2 - x_r3)
 5     current-to-best/1     x_i + F (x_best - x_i) + F (x_r1 - x_r2)
 6     rand-to-best/1        x_r1 + F (x_best - x_r1) + F (x_r2 - x_r3)
====  ====================  ==========================================================

Crossovers: 0 = binomial, 1 = exponential (see :func:`crossover_mask`).
"""

from __future__ import annotations

import numpy as np

MUTATIONS: tuple[str, ...] = (
    "rand/1",
    "best/1",
    "rand/2",
    "best/2",
    "current-to-rand/1",
    "current-to-best/1",
    "rand-to-best/1",
)
CROSSOVERS: tuple[str, ...] = ("bin", "exp")
N_MUTATIONS = len(MUTATIONS)
N_CROSSOVERS = len(CROSSOVERS)
N_DONORS = 5  # the most donors any mutation needs (rand/2); MIN_POPULATION = N_DONORS + 1

# Every mutation is  v = x[a] + F (x[b] - x[c]) + F (x[p] - x[q]).  Columns of the candidate
# matrix: 0 = i, 1 = best, 2..6 = r1..r5.  A one-difference operator uses (p, q) = (i, i), whose
# difference is exactly zero in floating point.
_I, _B, _R1, _R2, _R3, _R4, _R5 = range(7)
_TERMS = np.array(
    [
        # a    b    c    p    q
        [_R1, _R2, _R3, _I, _I],  # rand/1
        [_B, _R1, _R2, _I, _I],  # best/1
        [_R1, _R2, _R3, _R4, _R5],  # rand/2
        [_B, _R1, _R2, _R3, _R4],  # best/2
        [_I, _R1, _I, _R2, _R3],  # current-to-rand/1
        [_I, _B, _I, _R1, _R2],  # current-to-best/1
        [_R1, _B, _R1, _R2, _R3],  # rand-to-best/1
    ],
    dtype=np.intp,
)


def mutation_index(name: str | int) -> int:
    """Operator id from a name such as ``"rand/1"`` (ids pass through after a range check).

    Args:
        name: a name of `MUTATIONS` or an id.

    Returns:
        The id, 0..6.

    Raises:
        ValueError: an unknown name or an id out of range.
    """
    if isinstance(name, str):
        try:
            return MUTATIONS.index(name)
        except ValueError:
            raise ValueError(f"unknown mutation {name!r}; choose from {MUTATIONS}") from None
    idx = int(name)
    if not 0 <= idx < N_MUTATIONS:
        raise ValueError(f"mutation id {idx} outside 0..{N_MUTATIONS - 1}")
    return idx


def crossover_index(name: str | int) -> int:
    """Crossover id from ``"bin"``/``"binomial"`` or ``"exp"``/``"exponential"`` (or an id).

    Args:
        name: a name or an id.

    Returns:
        The id: 0 binomial, 1 exponential.

    Raises:
        ValueError: an unknown name or an id out of range.
    """
    if isinstance(name, str):
        key = {"binomial": "bin", "exponential": "exp"}.get(name, name)
        try:
            return CROSSOVERS.index(key)
        except ValueError:
            raise ValueError(f"unknown crossover {name!r}; choose from {CROSSOVERS}") from None
    idx = int(name)
    if not 0 <= idx < N_CROSSOVERS:
        raise ValueError(f"crossover id {idx} outside 0..{N_CROSSOVERS - 1}")
    return idx


# ---- randomness: one block of raw 64-bit words per draw, split the same way here and in fast.py
# shared with the compiled split in fast.py
_SHIFT53 = np.uint64(11)  # a word's top 53 bits make a double in [0, 1)
_SHIFT32 = np.uint64(32)
_LOW32 = np.uint64(0xFFFFFFFF)
_TWO_M53 = 2.0**-53
_TWO_M32 = 2.0**-32


def unit_doubles(words: np.ndarray) -> np.ndarray:
    """Uniforms in [0, 1) with 53 random bits, one per raw 64-bit word (numpy's own mapping).

    Args:
        words: raw uint64 words, any shape.

    Returns:
        Floats, the words' shape.
    """
    return (words >> _SHIFT53).astype(float) * _TWO_M53


def unit_halves(words: np.ndarray, count: int) -> np.ndarray:
    """``count`` uniforms in [0, 1) with 32 random bits, two per word (high half first).

    Half the raw draws of :func:`unit_doubles`; the crossover's ``u < Cr`` tests need no more
    resolution than 2**-32.

    Args:
        words: raw uint64 words (at least ceil(count / 2); flattened).
        count: how many uniforms.

    Returns:
        (count,) floats.
    """
    halves = np.empty((words.size, 2), dtype=np.uint64)
    halves[:, 0] = words >> _SHIFT32
    halves[:, 1] = words & _LOW32
    return halves.reshape(-1)[:count].astype(float) * _TWO_M32


def below(uniforms: np.ndarray, m: int | np.ndarray) -> np.ndarray:
    """Integers in ``0..m-1`` from uniforms in [0, 1): ``floor(u * m)``, kept < m (uniform to
    within ``m * 2**-53`` for 53-bit uniforms).

    Args:
        uniforms: floats in [0, 1), any shape.
        m: the range, a scalar or an array broadcasting against `uniforms`.

    Returns:
        intp integers, the broadcast shape.
    """
    return np.minimum((uniforms * m).astype(np.intp), np.asarray(m, dtype=np.intp) - 1)


def donor_words(rows: int, k: int = N_DONORS) -> int:
    """Raw words :func:`draw_donors` takes: one per donor.

    Args:
        rows: rows drawn.
        k: donors per row.

    Returns:
        rows x k.
    """
    return rows * k


def crossover_words(rows: int, d: int) -> int:
    """Raw words :func:`draw_crossover` takes: one per row for ``j``, then ``u`` two per word.

    Args:
        rows: rows drawn.
        d: the dimension.

    Returns:
        rows + ceil(rows x d / 2).
    """
    return rows + (rows * d + 1) // 2


def draw_donors(rng: np.random.Generator, n: int, rows: int, k: int = N_DONORS) -> np.ndarray:
    """Draw ``(rows, k)`` donor indices in ``0..n-1``: row i holds k indices distinct from each
    other and from i, uniformly over ordered k-subsets (sequential draw from the remaining set).

    Randomness: :func:`donor_words` raw words, row-major; donor c of a row is a rank uniform in
    ``0..n-2-c`` among the indices not yet taken (:func:`below` of :func:`unit_doubles`).

    Args:
        rng: the generation's generator (its bit generator's raw words are read).
        n: the population size.
        rows: rows to draw (individuals 0..rows-1).
        k: donors per row.

    Returns:
        (rows, k) intp donor indices.

    Raises:
        ValueError: n < k + 1.
    """
    if n < k + 1:
        raise ValueError(f"population {n} too small for {k} distinct donors (need >= {k + 1})")
    words = rng.bit_generator.random_raw(donor_words(rows, k))
    ranks = below(unit_doubles(words).reshape(rows, k), n - 1 - np.arange(k))
    out = np.empty((rows, k), dtype=np.intp)
    taken = np.arange(rows, dtype=np.intp)[:, None]  # excluded so far, sorted per row
    for j in range(k):
        r = ranks[:, j].copy()
        # Map r from 0..(n-len(taken)-1) onto the values not taken: walk the sorted exclusions.
        for col in range(taken.shape[1]):
            r += r >= taken[:, col]
        out[:, j] = r
        taken = np.sort(np.concatenate([taken, r[:, None]], axis=1), axis=1)
    return out


def mutate(
    X: np.ndarray,
    mutation: np.ndarray,
    F: np.ndarray,
    best: int | np.ndarray,
    donors: np.ndarray,
) -> np.ndarray:
    """Mutants for rows ``i = 0..m-1`` (m = len(mutation)) of population ``X`` (n, d).

    Formulas in the module docstring.

    Args:
        X: the population (n, d).
        mutation: (m,) operator ids.
        F: (m,) scale factors.
        best: the guide index (scalar or (m,)).
        donors: (m, 5) from :func:`draw_donors`.

    Returns:
        (m, d) mutants, not clamped.
    """
    m = len(mutation)
    cand = np.empty((m, 2 + N_DONORS), dtype=np.intp)
    cand[:, _I] = np.arange(m)
    cand[:, _B] = best
    cand[:, 2:] = donors[:, :N_DONORS]
    idx = np.take_along_axis(cand, _TERMS[np.asarray(mutation, dtype=np.intp)], axis=1)
    Fc = np.asarray(F, dtype=float)[:, None]
    return X[idx[:, 0]] + Fc * (X[idx[:, 1]] - X[idx[:, 2]]) + Fc * (X[idx[:, 3]] - X[idx[:, 4]])


def draw_crossover(rng: np.random.Generator, rows: int, d: int) -> tuple[np.ndarray, np.ndarray]:
    """Randomness for :func:`crossover_mask`: uniforms ``u`` (rows, d) and a start/forced
    index ``j`` (rows,) per row; the same draws serve both crossover kinds.

    :func:`crossover_words` raw words: ``j`` from the first ``rows`` (:func:`below` of
    :func:`unit_doubles`), then ``u`` row-major from :func:`unit_halves`.

    Args:
        rng: the generation's generator (its bit generator's raw words are read).
        rows: rows to draw.
        d: the dimension.

    Returns:
        (u (rows, d) floats in [0, 1), j (rows,) intp in 0..d-1).
    """
    words = rng.bit_generator.random_raw(crossover_words(rows, d))
    j = below(unit_doubles(words[:rows]), d)
    return unit_halves(words[rows:], rows * d).reshape(rows, d), j


def crossover_mask(
    crossover: np.ndarray, Cr: np.ndarray, u: np.ndarray, j: np.ndarray
) -> np.ndarray:
    """Boolean (m, d) mask: True where the trial takes the mutant's gene.

    Binomial (0): gene k from the mutant iff ``u[k] < Cr`` or ``k == j`` (forced j_rand).
    Exponential (1): a circular run starting at ``j``; it has length
    ``L = 1 + #(leading True in u[0..d-2] < Cr)`` (capped at d), i.e. after each copied gene the
    run continues while the next uniform is below Cr; genes ``j, j+1, .., j+L-1 (mod d)``.

    Args:
        crossover: (m,) ids, 0 binomial / 1 exponential.
        Cr: (m,) crossover rates.
        u: (m, d) uniforms (:func:`draw_crossover`).
        j: (m,) start / forced indices.

    Returns:
        (m, d) bool mask.
    """
    m, d = u.shape
    cr = np.asarray(Cr, dtype=float)[:, None]
    cols = np.arange(d)
    below = u < cr
    forced = cols[None, :] == np.asarray(j)[:, None]
    binom = below | forced
    run = 1 + np.cumprod(below[:, : d - 1], axis=1).sum(axis=1)
    expo = ((cols[None, :] - np.asarray(j)[:, None]) % d) < run[:, None]
    return np.where(np.asarray(crossover, dtype=bool)[:, None], expo, binom)


def crossover(
    x: np.ndarray,
    v: np.ndarray,
    crossover_ids: np.ndarray,
    Cr: np.ndarray,
    u: np.ndarray,
    j: np.ndarray,
) -> np.ndarray:
    """Trials: mutant genes where :func:`crossover_mask` is True, parent genes elsewhere.

    Args:
        x: (m, d) parents.
        v: (m, d) mutants.
        crossover_ids: (m,) ids, 0 binomial / 1 exponential.
        Cr: (m,) crossover rates.
        u: (m, d) uniforms.
        j: (m,) start / forced indices.

    Returns:
        (m, d) trials, not clamped.
    """
    return np.where(crossover_mask(crossover_ids, Cr, u, j), v, x)
