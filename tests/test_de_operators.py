"""DE operators on hand-computed populations (donor indices and uniforms passed explicitly)."""

from __future__ import annotations

import numpy as np
import pytest

from planner_core.search.de.operators import (
    MUTATIONS,
    crossover,
    crossover_index,
    crossover_mask,
    draw_crossover,
    draw_donors,
    mutate,
    mutation_index,
)

# Six 2-d points; row 0 is the current individual in the single-row tests below.
X = np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0], [2.0, 2.0], [4.0, 0.0], [0.0, 8.0]])
DONORS = np.array([[1, 2, 3, 4, 5]])  # r1..r5
BEST = 3
F = np.array([0.5])

# By hand, with i = 0, best = 3, r = (1, 2, 3, 4, 5), F = 0.5:
EXPECTED = {
    "rand/1": [0.0, -0.5],  # x1 + .5 (x2 - x3) = (1,0) + .5 (-2,-1)
    "best/1": [2.5, 1.5],  # x3 + .5 (x1 - x2) = (2,2) + .5 (1,-1)
    "rand/2": [2.0, -4.5],  # x1 + .5 (x2 - x3) + .5 (x4 - x5) = (0,-.5) + .5 (4,-8)
    "best/2": [1.5, 2.5],  # x3 + .5 (x1 - x2) + .5 (x3 - x4) = (2.5,1.5) + .5 (-2,2)
    "current-to-rand/1": [-0.5, -0.5],  # x0 + .5 (x1 - x0) + .5 (x2 - x3)
    "current-to-best/1": [1.5, 0.5],  # x0 + .5 (x3 - x0) + .5 (x1 - x2)
    "rand-to-best/1": [0.5, 0.5],  # x1 + .5 (x3 - x1) + .5 (x2 - x3)
}


@pytest.mark.parametrize("name", MUTATIONS)
def test_each_mutation_by_hand(name: str) -> None:
    v = mutate(X, np.array([mutation_index(name)]), F, BEST, DONORS)
    np.testing.assert_allclose(v[0], EXPECTED[name])


def test_mutations_vectorised_match_row_by_row() -> None:
    rng = np.random.default_rng(0)
    n, d = 14, 4
    pop = rng.random((n, d))
    ops = np.arange(n) % len(MUTATIONS)
    Fs = rng.random(n)
    donors = draw_donors(rng, n, n)
    guide = rng.integers(0, n, size=n)
    all_at_once = mutate(pop, ops, Fs, guide, donors)
    for i in range(n):
        # Row i computed alone: rotate the population so that i becomes row 0.
        perm = np.roll(np.arange(n), -i)
        inv = np.argsort(perm)
        one = mutate(pop[perm], ops[i : i + 1], Fs[i : i + 1], inv[guide[i]], inv[donors[i]][None])
        np.testing.assert_allclose(all_at_once[i], one[0])


def test_one_difference_operators_ignore_r4_r5() -> None:
    a = mutate(X, np.array([0]), F, BEST, np.array([[1, 2, 3, 4, 5]]))
    b = mutate(X, np.array([0]), F, BEST, np.array([[1, 2, 3, 5, 4]]))
    np.testing.assert_array_equal(a, b)


def test_donors_distinct_and_exclude_self() -> None:
    rng = np.random.default_rng(1)
    n = 6
    counts = np.zeros((n, n), dtype=int)
    for _ in range(300):
        r = draw_donors(rng, n, n)
        assert r.shape == (n, 5)
        full = np.concatenate([np.arange(n)[:, None], r], axis=1)
        assert all(len(set(row)) == 6 for row in full.tolist())
        for i in range(n):
            counts[i, r[i, 0]] += 1
    # With n = 6 the 5 donors are a permutation of the others; r1 is uniform over them.
    off = counts[~np.eye(n, dtype=bool)]
    assert off.min() > 30 and np.all(np.diag(counts) == 0)


def test_donors_need_enough_individuals() -> None:
    with pytest.raises(ValueError):
        draw_donors(np.random.default_rng(0), 5, 5)


def test_binomial_by_hand() -> None:
    u = np.array([[0.1, 0.7, 0.3, 0.9]])
    mask = crossover_mask(np.array([0]), np.array([0.5]), u, np.array([3]))
    np.testing.assert_array_equal(mask[0], [True, False, True, True])  # j_rand = 3 forced
    mask = crossover_mask(np.array([0]), np.array([0.0]), u, np.array([1]))
    np.testing.assert_array_equal(mask[0], [False, True, False, False])  # only j_rand


def test_exponential_by_hand() -> None:
    u = np.array([[0.2, 0.4, 0.8, 0.1, 0.0]])  # continue, continue, stop -> length 3
    mask = crossover_mask(np.array([1]), np.array([0.5]), u, np.array([2]))
    np.testing.assert_array_equal(mask[0], [False, False, True, True, True])
    mask = crossover_mask(np.array([1]), np.array([0.5]), u, np.array([4]))  # wraps around
    np.testing.assert_array_equal(mask[0], [True, True, False, False, True])
    mask = crossover_mask(np.array([1]), np.array([0.0]), u, np.array([1]))  # length >= 1
    np.testing.assert_array_equal(mask[0], [False, True, False, False, False])
    mask = crossover_mask(np.array([1]), np.array([1.0]), u, np.array([3]))  # capped at d
    assert mask.all()


def test_exponential_run_length_is_geometric() -> None:
    rng = np.random.default_rng(2)
    m, d, cr = 20_000, 30, 0.7
    u, j = draw_crossover(rng, m, d)
    lengths = crossover_mask(np.ones(m, int), np.full(m, cr), u, j).sum(axis=1)
    expected_mean = (1 - cr**d) / (1 - cr)  # E[min(Geometric, d)]
    assert abs(lengths.mean() - expected_mean) < 0.05
    runs = crossover_mask(np.ones(m, int), np.full(m, cr), u, j)
    # each mask is one contiguous circular run: exactly one False -> True transition (or all)
    starts = (runs & ~np.roll(runs, 1, axis=1)).sum(axis=1)
    assert np.all((starts == 1) | runs.all(axis=1))


def test_mixed_crossover_rows_and_trial_values() -> None:
    x = np.zeros((2, 4))
    v = np.ones((2, 4))
    u = np.array([[0.9, 0.1, 0.9, 0.9], [0.1, 0.9, 0.1, 0.1]])
    t = crossover(x, v, np.array([0, 1]), np.array([0.5, 0.5]), u, np.array([0, 2]))
    np.testing.assert_array_equal(t, [[1, 1, 0, 0], [0, 0, 1, 1]])


def test_name_lookup() -> None:
    assert [mutation_index(n) for n in MUTATIONS] == list(range(7))
    assert crossover_index("binomial") == 0 and crossover_index("exp") == 1
    with pytest.raises(ValueError):
        mutation_index("rand/3")
    with pytest.raises(ValueError):
        crossover_index(2)
