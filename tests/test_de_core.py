"""DE core: Deb's rule and ranking, clamping, budget accounting, determinism, improvement."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from planner_core.search.de import (
    Config,
    DEState,
    FixedConfigurator,
    Progress,
    ask,
    ask_words,
    deb_best,
    deb_better,
    deb_order,
    init,
    run,
    step,
    tell,
)


class ConstrainedSphere:
    """min ||x - o||^2 on [-5, 5]^d s.t. ||x - c|| <= 1 (o outside the ball): optimum known."""

    def __init__(self, d: int = 10) -> None:
        self.lower = np.full(d, -5.0)
        self.upper = np.full(d, 5.0)
        self.o = np.full(d, 2.0)
        self.c = np.full(d, -1.0)
        self.calls: list[int] = []

    def evaluate(self, X: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        self.calls.append(len(X))
        f = ((X - self.o) ** 2).sum(axis=1)
        phi = np.maximum(np.linalg.norm(X - self.c, axis=1) - 1.0, 0.0)
        return f, phi

    @property
    def optimum(self) -> float:
        return float((np.linalg.norm(self.o - self.c) - 1.0) ** 2)


def _state(X: np.ndarray, f: np.ndarray, phi: np.ndarray, budget: int = 10_000) -> DEState:
    return DEState(X, f, phi, deb_best(f, phi), 0, len(X), budget, 0)


def _cfg(n: int, mutation: int = 0, crossover: int = 0, F: float = 0.5, Cr: float = 0.9) -> Config:
    return Config(np.full(n, mutation), np.full(n, crossover), np.full(n, F), np.full(n, Cr))


# ---------------------------------------------------------------- Deb's rule and ranking


def test_deb_better_hand_pairs() -> None:
    #            trial (f, phi)   parent (f, phi)  trial wins?
    cases = [
        ((5.0, 0.0), (1.0, 0.5), True),  # feasible beats infeasible whatever f
        ((1.0, 0.5), (5.0, 0.0), False),  # infeasible never beats feasible
        ((9.0, 0.2), (0.0, 0.3), True),  # both infeasible: smaller phi
        ((0.0, 0.3), (9.0, 0.2), False),
        ((1.0, 0.0), (2.0, 0.0), True),  # both feasible: smaller f
        ((2.0, 0.0), (2.0, 0.0), False),  # full tie keeps the parent
        ((1.0, 0.4), (2.0, 0.4), True),  # equal phi > 0: f decides
        ((3.0, 0.4), (2.0, 0.4), False),
        ((-1.0, 0.0), (1.0, 0.0), True),  # negative objectives
    ]
    rows = np.array([(t[0], t[1], p[0], p[1]) for t, p, _ in cases])
    ft, pt, fp, pp = rows.T
    np.testing.assert_array_equal(deb_better(ft, pt, fp, pp), [w for *_, w in cases])


def test_deb_ranking_and_best() -> None:
    f = np.array([0.0, 5.0, 3.0, -10.0, 3.0])
    phi = np.array([1.0, 0.0, 0.0, 2.0, 0.0])
    assert deb_best(f, phi) == 2  # lowest phi, then lowest f, first on a full tie
    np.testing.assert_array_equal(deb_order(f, phi), [2, 4, 1, 0, 3])
    assert deb_best(np.array([3.0, 1.0]), np.array([0.5, 0.7])) == 0  # all infeasible


def test_tell_applies_deb_rule_and_keeps_state_immutable() -> None:
    X = np.arange(12.0).reshape(6, 2) / 12
    f = np.array([1.0, 1.0, 1.0, 1.0, 1.0, 1.0])
    phi = np.array([0.0, 0.0, 0.5, 0.5, 0.0, 0.2])
    s = _state(X, f, phi)
    trials = np.full((6, 2), 0.99)
    ft = np.array([0.5, 1.0, 9.0, 0.1, 0.0, np.nan])
    pt = np.array([0.0, 0.0, 0.4, 0.5, 0.1, 0.2])
    new = tell(s, trials, ft, pt)
    np.testing.assert_array_equal(new.X[:, 0] == 0.99, [True, False, True, True, False, False])
    assert new.f[5] == 1.0  # NaN f is treated as +inf and loses the f tie-break
    assert tell(s, trials, ft, np.full(6, np.nan)).X[:, 0].max() != 0.99  # NaN phi loses
    assert new.generation == 1 and new.evaluations == s.evaluations + 6
    assert new.best == 0 and s.X[0, 0] == 0.0  # old state untouched
    with pytest.raises(ValueError):
        new.X[0, 0] = 1.0  # read-only arrays
    with pytest.raises(dataclasses.FrozenInstanceError):
        new.generation = 5  # type: ignore[misc]


# ---------------------------------------------------------------- ask: clamping, purity


@pytest.mark.slow  # measured 15 s (issue 35: default suite <= 5 min)
def test_trials_are_clamped_to_unit_box() -> None:
    rng = np.random.default_rng(0)
    X = rng.choice([0.0, 1.0], size=(10, 6))
    s = _state(X, np.zeros(10), np.zeros(10))
    T = ask(s, _cfg(10, mutation=2, F=1.0, Cr=1.0))  # rand/2, F = 1 leaves the box
    assert T.min() >= 0.0 and T.max() <= 1.0
    assert np.any(T == 0.0) and np.any(T == 1.0)


def test_ask_is_pure_and_uses_the_configuration() -> None:
    p = ConstrainedSphere(4)
    s = init(p, seed=3, population=8)
    a = ask(s, _cfg(8))
    np.testing.assert_array_equal(a, ask(s, _cfg(8)))
    assert not np.array_equal(a, ask(s, _cfg(8, mutation=1)))
    zero = ask(s, _cfg(8, crossover=0, Cr=0.0, F=0.0))  # F = 0 rand/1: one gene of x_r1
    assert np.all((zero != s.X).sum(axis=1) <= 1)
    with pytest.raises(ValueError, match="mutation ids"):
        ask(s, _cfg(8, mutation=7))
    with pytest.raises(ValueError, match="crossover ids"):
        ask(s, _cfg(8, crossover=-1))
    with pytest.raises(ValueError, match="NaN"):
        ask(s, _cfg(8, F=float("nan")))
    np.testing.assert_array_equal(ask(s, _cfg(8, F=1.7, Cr=-3.0)), ask(s, _cfg(8, F=1.0, Cr=0.0)))
    with pytest.raises(ValueError):
        ask(s, _cfg(7))


# ---------------------------------------------------------------- budget accounting


@pytest.mark.parametrize(("budget", "gens"), [(1050, 10), (1000, 9), (100, 0), (101, 1)])
def test_budget_accounting(budget: int, gens: int) -> None:
    p = ConstrainedSphere(3)
    r = run(p, configurator="fixed", seed=0, population=100, budget=budget)
    assert sum(p.calls) == budget == r.evaluations  # initial population counts, never exceeds
    assert p.calls[0] == 100 and r.generations == gens
    assert len(r.history.best_f) == gens + 1
    assert r.history.evaluations[-1] == budget


def test_short_last_generation_only_touches_first_rows() -> None:
    p = ConstrainedSphere(3)
    s = init(p, seed=1, population=10, budget=25)
    conf = FixedConfigurator()
    s = dataclasses.replace(s, memory=conf.init(s))
    s, _ = step(s, p, conf)
    last, out = step(s, p, conf)
    assert len(out.success) == 5 and last.evaluations == 25 and last.done
    np.testing.assert_array_equal(last.X[5:], s.X[5:])
    with pytest.raises(ValueError):
        init(p, seed=0, population=10, budget=9)
    with pytest.raises(ValueError):
        init(p, seed=0, population=5)


# ---------------------------------------------------------------- determinism and progress


def test_same_seed_same_result_different_seed_different() -> None:
    p = ConstrainedSphere(6)
    a = run(p, configurator="random", seed=7, population=20, budget=600)
    b = run(p, configurator="random", seed=7, population=20, budget=600)
    c = run(p, configurator="random", seed=8, population=20, budget=600)
    np.testing.assert_array_equal(a.x, b.x)
    np.testing.assert_array_equal(a.state.X, b.state.X)
    np.testing.assert_array_equal(a.history.best_f, b.history.best_f)
    assert a.f == b.f and a.phi == b.phi
    assert not np.array_equal(a.state.X, c.state.X)


def test_callback_reports_each_generation() -> None:
    seen: list[Progress] = []
    r = run(
        ConstrainedSphere(3),
        configurator="fixed",
        seed=0,
        population=10,
        budget=95,
        callback=seen.append,
    )
    assert [s.generation for s in seen] == list(range(r.generations + 1))
    assert seen[-1].evaluations == 95 and seen[-1].budget == 95
    np.testing.assert_array_equal([s.best_f for s in seen], r.history.best_f)


def test_run_reaches_the_constrained_optimum() -> None:
    p = ConstrainedSphere(10)
    r = run(p, configurator="fixed", seed=0, population=40, budget=6000)
    assert r.phi == 0.0 and r.feasible
    assert r.history.feasible_fraction[0] == 0.0  # nobody feasible at the start
    assert r.f < p.optimum * 1.05
    f, phi = p.evaluate(r.x[None])
    assert f[0] == r.f and phi[0] == r.phi  # best reported in problem space
    # history is monotone under Deb's elitist selection
    assert np.all(np.diff(r.history.best_phi) <= 0)


class SeededSphere(ConstrainedSphere):
    """The same problem with the optional ``initial_population`` hook (problem-space points)."""

    def initial_population(self, rng: np.random.Generator, n: int) -> np.ndarray:
        X = rng.uniform(-5.0, 5.0, (n, len(self.lower)))
        X[0] = self.c  # the ball centre: feasible
        X[1] = 9.0  # outside the bounds: clamped into the box
        return X


def test_initial_population_hook_is_used_and_clamped() -> None:
    p = SeededSphere(4)
    s = init(p, seed=2, population=8)
    np.testing.assert_allclose(s.X[0], (p.c - p.lower) / (p.upper - p.lower))
    np.testing.assert_array_equal(s.X[1], 1.0)
    assert s.phi[0] == 0.0 and s.feasible_fraction >= 1 / 8
    np.testing.assert_array_equal(s.X, init(p, seed=2, population=8).X)  # seeded generator
    assert not np.array_equal(s.X, init(p, seed=3, population=8).X)

    class Wrong(SeededSphere):
        def initial_population(self, rng: np.random.Generator, n: int) -> np.ndarray:
            return np.zeros((n - 1, 4))

    with pytest.raises(ValueError):
        init(Wrong(4), seed=0, population=8)


def test_step_gives_the_trials_of_configure_then_ask() -> None:
    """ask's words come first in a generation's stream, so step == configure + ask."""
    from planner_core.search.de import AdaptiveConfigurator, generation_rng, step

    p = ConstrainedSphere(5)
    conf = AdaptiveConfigurator()
    s = init(p, seed=4, population=12, budget=120)
    s = dataclasses.replace(s, memory=conf.init(s))
    _, out = step(s, p, conf)
    rng = generation_rng(s)
    rng.bit_generator.random_raw(len(ask_words(s)))  # skip ask's words, as step does
    cfg = conf.configure(s, rng)
    np.testing.assert_array_equal(out.trials, ask(s, cfg))


def test_reused_streams_change_nothing() -> None:
    """run() reuses one Streams per run; a loop of plain step() calls gives the same run."""
    from planner_core.search.de import AdaptiveConfigurator, step

    p = ConstrainedSphere(4)
    conf = AdaptiveConfigurator()
    r = run(p, configurator=conf, seed=9, population=10, budget=150)
    s = init(p, seed=9, population=10, budget=150)
    s = dataclasses.replace(s, memory=conf.init(s))
    while not s.done:
        s, _ = step(s, p, conf)
    np.testing.assert_array_equal(s.X, r.state.X)
    assert s.best_f == r.f and s.best_phi == r.phi
