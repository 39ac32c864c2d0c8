"""The compiled trial generation equals the numpy reference operators bit for bit."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from planner_core.search.de import fast, to_problem
from planner_core.search.de import operators as op


@pytest.mark.parametrize("seed", range(40))
def test_ask_equals_reference_operators(seed: int) -> None:
    rng = np.random.default_rng(seed)
    n = int(rng.integers(6, 120))
    d = int(rng.integers(1, 90))
    k = int(rng.integers(1, n + 1))
    X = rng.random((n, d))
    mutation = rng.integers(0, op.N_MUTATIONS, k)
    cross = rng.integers(0, op.N_CROSSOVERS, k)
    F = rng.random(k) * 1.5 - 0.2  # rates outside [0, 1] are clipped
    Cr = rng.random(k) * 1.2 - 0.1
    Cr[: k // 4] = 1.0  # full-length exponential runs
    Cr[k // 4 : k // 3] = 0.0  # binomial with only the forced gene
    best = int(rng.integers(0, n))
    r_ref, r_fast = np.random.default_rng(seed + 1000), np.random.default_rng(seed + 1000)
    donors = op.draw_donors(r_ref, n, k)
    assert all(len({i, *row}) == op.N_DONORS + 1 for i, row in enumerate(donors))
    u, j = op.draw_crossover(r_ref, k, d)
    Fc, Crc = np.clip(F, 0.0, 1.0), np.clip(Cr, 0.0, 1.0)  # fast.ask clips the rates
    ref = np.clip(op.crossover(X[:k], op.mutate(X, mutation, Fc, best, donors), cross, Crc, u, j),
                  0.0, 1.0)
    words = r_fast.bit_generator.random_raw(op.donor_words(k) + op.crossover_words(k, d))
    got = fast.ask(words, X, mutation, F, best, cross, Cr)
    assert np.array_equal(ref, got)
    lower, upper = -rng.random(d) * 10, rng.random(d) * 10
    box = SimpleNamespace(lower=lower, upper=upper)
    again, points = fast.ask(words, X, mutation, F, best, cross, Cr, (lower, upper - lower))
    assert np.array_equal(again, got) and np.array_equal(points, to_problem(box, got))
    assert r_ref.random() == r_fast.random()  # the same draws were consumed


def test_too_small_population() -> None:
    with pytest.raises(ValueError, match="too small"):
        fast.ask(np.zeros(30, np.uint64), np.zeros((5, 2)), np.zeros(5, int), np.ones(5), 0,
                 np.zeros(5, int), np.ones(5))  # fmt: skip
