"""The compiled trial generation equals the numpy reference operators bit for bit."""

from __future__ import annotations

import numpy as np
import pytest

from planner_core.de import fast
from planner_core.de import operators as op


@pytest.mark.parametrize("seed", range(40))
def test_trials_equal_reference_operators(seed: int) -> None:
    rng = np.random.default_rng(seed)
    n = int(rng.integers(6, 120))
    d = int(rng.integers(1, 90))
    k = int(rng.integers(1, n + 1))
    X = rng.random((n, d))
    mutation = rng.integers(0, op.N_MUTATIONS, k)
    cross = rng.integers(0, op.N_CROSSOVERS, k)
    F = rng.random(k) * 1.5  # F > 1 pushes mutants out of the box: clamping is exercised
    Cr = rng.random(k)
    Cr[: k // 4] = 1.0  # full-length exponential runs
    Cr[k // 4 : k // 3] = 0.0  # binomial with only the forced gene
    best = int(rng.integers(0, n))
    donors = op.draw_donors(rng, n, k)
    u, j = op.draw_crossover(rng, k, d)
    ref = np.clip(op.crossover(X[:k], op.mutate(X, mutation, F, best, donors), cross, Cr, u, j),
                  0.0, 1.0)
    got = fast.trials(X, mutation, F, best, donors, cross, Cr, u, j)
    assert np.array_equal(ref, got)


@pytest.mark.parametrize("seed", range(20))
def test_donors_equal_reference_draw(seed: int) -> None:
    n = 6 + seed * 7
    rows = max(1, n - seed)
    r1, r2 = np.random.default_rng(seed), np.random.default_rng(seed)
    a = op.draw_donors(r1, n, rows)
    b = fast.draw_donors(r2, n, rows)
    assert np.array_equal(a, b)
    assert r1.random() == r2.random()  # the same draws were consumed
    assert all(len({i, *row}) == 6 for i, row in enumerate(b))


def test_too_small_population() -> None:
    with pytest.raises(ValueError, match="too small"):
        fast.draw_donors(np.random.default_rng(0), 5, 5)
