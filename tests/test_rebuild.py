"""The destroy-and-repair move (planner_core.search.rebuild): a window of consecutive hover
points replaced by new sites for the sensors it served, raced against the incumbent."""

from __future__ import annotations

import numpy as np
import pytest

from planner_core.model.problem import Problem
from planner_core.search.construct import candidate_plans, candidate_sites
from planner_core.search.descent import hover_of
from planner_core.search.rebuild import OWNS, WINDOWS, Rebuilder, rebuild
from tests.conftest import SUITE


@pytest.fixture(scope="module")
def t05() -> Problem:
    return Problem(SUITE / "T05.json")


def _plan(problem: Problem) -> np.ndarray:
    X, _ = candidate_plans(problem, 0, 30)
    f, phi = problem.evaluate(X)
    return X[np.lexsort((f, phi))[0]]


def test_a_draw_keeps_the_points_outside_the_window_in_order_and_serves_the_window_sensors(
        t05: Problem) -> None:
    """Each draw keeps a prefix and a suffix of the plan, puts 1 .. w + 1 candidate sites in
    the gap, and never holds more than I_max points."""
    P, T = hover_of(t05.breakdown(_plan(t05)))
    P, T = P[T > 0], T[T > 0]
    rb = Rebuilder(t05)
    sites = {tuple(s) for s in rb.sites}
    rng = np.random.default_rng(0)
    drawn = 0
    for _ in range(40):
        Q = rb.draw(P, T, rng)
        if Q is None:
            continue
        drawn += 1
        assert len(Q) <= t05.n_points
        # the longest common prefix and suffix with P leave a gap of at most max(WINDOWS) points
        pre = next((i for i in range(min(len(P), len(Q))) if not np.array_equal(P[i], Q[i])),
                   min(len(P), len(Q)))
        suf = next((i for i in range(min(len(P), len(Q)) - pre)
                    if not np.array_equal(P[-1 - i], Q[-1 - i])), min(len(P), len(Q)) - pre)
        removed, added = len(P) - pre - suf, len(Q) - pre - suf
        assert removed <= max(WINDOWS) and 0 <= added <= max(WINDOWS) + 1
        assert all(tuple(q) in sites for q in Q[pre:len(Q) - suf])
    assert drawn >= 20
    assert 0.0 < OWNS < 1.0


def test_rebuild_is_seeded_counted_and_never_worse(t05: Problem) -> None:
    x = _plan(t05)
    f0 = float(t05.evaluate(x[None])[0][0])
    calls: list[int] = []

    def counted(X: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        calls.append(len(X))
        return t05.evaluate(X)

    r = rebuild(t05, x, counted, trials=150, seed=3)
    assert r is not None and sum(calls) == r.evaluations <= 150
    f, phi = t05.evaluate(r.x[None])
    assert phi[0] == 0.0 and f[0] == r.f <= f0 and r.f_start == f0
    same = rebuild(t05, x, t05.evaluate, trials=150, seed=3, rebuilder=Rebuilder(t05))
    other = rebuild(t05, x, t05.evaluate, trials=150, seed=3, stream=2)
    assert same is not None and other is not None
    assert same.x.tobytes() == r.x.tobytes() and other.x.tobytes() != r.x.tobytes()
    assert rebuild(t05, x, t05.evaluate, trials=0, seed=3) is None


def test_rebuild_leaves_fixed_length_plans_and_infeasible_plans_alone(t05: Problem) -> None:
    fixed = Problem(SUITE / "T05.json", variable_length=False)
    x = fixed.initial_population(np.random.default_rng(0), 1)[0]
    assert rebuild(fixed, x, fixed.evaluate, trials=50, seed=0) is None
    bad = _plan(t05).copy().reshape(-1, 4)
    bad[:, 2] = 0.0  # no hover time: no sensor served (C4)
    assert rebuild(t05, bad.reshape(-1), t05.evaluate, trials=50, seed=0) is None


def test_the_candidate_sites_are_built_once(t05: Problem,
                                            monkeypatch: pytest.MonkeyPatch) -> None:
    import planner_core.search.construct as construct

    built: list[int] = []

    def spy(problem: Problem, extra: np.ndarray | None = None) -> np.ndarray:
        built.append(1)
        return candidate_sites(problem, extra)

    x = _plan(t05)
    monkeypatch.setattr(construct, "candidate_sites", spy)
    rb = Rebuilder(t05)
    rebuild(t05, x, t05.evaluate, trials=60, seed=1, rebuilder=rb)
    rebuild(t05, x, t05.evaluate, trials=60, seed=2, rebuilder=rb)
    assert built == [1]


def test_the_snap_to_the_nearest_site_equals_the_reference(t05: Problem) -> None:
    """`Rebuilder.nearest` (a k-d tree, then the exact squared distances near the nearest)
    picks the reference's site, the first index of least squared distance over all sites:
    on random points, on the sites themselves, and on exact ties (points halfway between
    sites of an integer grid, where the first index must win)."""
    from planner_core.search.rebuild import nearest_reference

    rb = Rebuilder(t05)
    sites = rb.sites
    rng = np.random.default_rng(7)
    pts = np.vstack([rng.uniform(sites.min(), sites.max(), (400, 2)), sites,
                     0.5 * (sites[:-1] + sites[1:])])
    assert np.array_equal(rb.nearest(pts), nearest_reference(sites, pts))

    grid = Rebuilder(t05)
    xs, ys = np.meshgrid(np.arange(6.0) * 100.0, np.arange(5.0) * 100.0)
    grid._sites = np.column_stack([xs.ravel(), ys.ravel()])[::-1].copy()  # ties: order matters
    ties = np.array([[50.0, 50.0], [150.0, 200.0], [250.0, 350.0], [0.0, 50.0], [500.0, 450.0]])
    far = np.array([[-1e4, -1e4], [2e4, 7e3]])
    q = np.vstack([ties, far, grid._sites])
    assert np.array_equal(grid.nearest(q), nearest_reference(grid._sites, q))
    # beyond any map (squares overflow) and non-finite points: the reference's answer
    huge = Rebuilder(t05)
    huge._sites = np.array([[0.0, 0.0], [1.3e154, 0.0]])
    q = np.array([[2.6e154, 0.0], [np.nan, 1.0], [np.inf, 0.0], [1.0, 1.0]])
    with np.errstate(over="ignore", invalid="ignore"):  # the overflow is the case tested
        assert np.array_equal(huge.nearest(q), nearest_reference(huge._sites, q))
    grid._sites = grid._sites[::-1].copy()  # new sites: a new tree
    q = np.vstack([ties, grid._sites])
    assert np.array_equal(grid.nearest(q), nearest_reference(grid._sites, q))


def test_unique_rows_equals_numpys_unique_along_rows() -> None:
    from planner_core.search.rebuild import _unique_rows

    rng = np.random.default_rng(3)
    for _ in range(300):
        a = rng.integers(-3, 4, size=(int(rng.integers(0, 8)), 2)).astype(float) * 50.0
        assert np.array_equal(_unique_rows(a), np.unique(a, axis=0))
