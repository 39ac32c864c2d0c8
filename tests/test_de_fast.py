"""The compiled trial generation equals the numpy reference operators bit for bit."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from planner_core.de import fast, to_problem
from planner_core.de import operators as op


@pytest.mark.parametrize("seed", range(40))
def test_ask_equals_reference_operators(seed: int) -> None:
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
    r_ref, r_fast = np.random.default_rng(seed + 1000), np.random.default_rng(seed + 1000)
    donors = op.draw_donors(r_ref, n, k)
    assert all(len({i, *row}) == op.N_DONORS + 1 for i, row in enumerate(donors))
    u, j = op.draw_crossover(r_ref, k, d)
    ref = np.clip(op.crossover(X[:k], op.mutate(X, mutation, F, best, donors), cross, Cr, u, j),
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


@pytest.mark.parametrize("seed", range(20))
def test_select_equals_deb_rule_reference(seed: int) -> None:
    from planner_core.de import deb_best, deb_better

    rng = np.random.default_rng(seed)
    n, d = int(rng.integers(6, 60)), int(rng.integers(1, 20))
    k = int(rng.integers(1, n + 1))
    X, T = rng.random((n, d)), rng.random((k, d))
    f, f_t = rng.integers(0, 4, n).astype(float), rng.integers(0, 4, k).astype(float)
    phi = np.where(rng.random(n) < 0.5, 0.0, rng.integers(1, 3, n).astype(float))
    phi_t = np.where(rng.random(k) < 0.5, 0.0, rng.integers(1, 3, k).astype(float))
    win = deb_better(f_t, phi_t, f[:k], phi[:k])
    X0 = X.copy()
    Xn, fn, phin, best = fast.select(X, f, phi, T, f_t, phi_t, win)
    ref_X = X.copy()
    ref_X[:k][win] = T[win]
    ref_f, ref_phi = f.copy(), phi.copy()
    ref_f[:k][win], ref_phi[:k][win] = f_t[win], phi_t[win]
    assert np.array_equal(Xn, ref_X) and np.array_equal(fn, ref_f)
    assert np.array_equal(phin, ref_phi) and best == deb_best(ref_f, ref_phi)
    assert np.array_equal(X, X0)  # inputs untouched
