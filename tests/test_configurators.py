"""Configurators: fixed, random, adaptive (learning from outcomes) and the registry."""

from __future__ import annotations

import numpy as np
import pytest

from planner_core.search.de import (
    AdaptiveConfigurator,
    Config,
    DEState,
    FixedConfigurator,
    Outcome,
    RandomConfigurator,
    deb_best,
    make_configurator,
    run,
)
from planner_core.search.de.configurators import ARMS, AdaptiveMemory, rank_credit


class ConstrainedRastrigin:
    """Shifted Rastrigin on [-5.12, 5.12]^d; a half-space and a ball: all infeasible at start."""

    def __init__(self, d: int) -> None:
        rng = np.random.default_rng(d)
        self.lower = np.full(d, -5.12)
        self.upper = np.full(d, 5.12)
        self.o = rng.uniform(-2, 2, d)

    def evaluate(self, X: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        Z = X - self.o
        f = 10 * X.shape[1] + (Z**2 - 10 * np.cos(2 * np.pi * Z)).sum(axis=1)
        g1 = X.sum(axis=1) / np.sqrt(X.shape[1]) + 2.0
        g2 = (X**2).mean(axis=1) - 4.0
        return f, np.maximum(g1, 0.0) + np.maximum(g2, 0.0)


def _state(n: int = 10, d: int = 3, memory: object = None) -> DEState:
    rng = np.random.default_rng(0)
    f, phi = rng.random(n), np.zeros(n)
    return DEState(rng.random((n, d)), f, phi, deb_best(f, phi), 0, n, 1000, 0, memory)


def _outcome(config: Config, success: np.ndarray, f_trial: np.ndarray | None = None) -> Outcome:
    k = len(success)
    f_parent = np.ones(k)
    if f_trial is None:
        f_trial = np.where(success, 0.5, 2.0)
    z = np.zeros(k)
    return Outcome(config, np.zeros((k, 2)), np.zeros((k, 2)), f_parent, z, f_trial, z, success,
                   k, 1000)  # fmt: skip


# ---------------------------------------------------------------- fixed and random


def test_fixed_default_is_rand1_bin() -> None:
    cfg = FixedConfigurator().configure(_state(), np.random.default_rng(0))
    assert [a.shape for a in cfg] == [(10,)] * 4
    assert set(cfg.mutation) == {0} and set(cfg.crossover) == {0}
    assert set(cfg.F) == {0.5} and set(cfg.Cr) == {0.9}
    other = FixedConfigurator("current-to-best/1", "exp", F=0.3, Cr=0.2)
    cfg = other.configure(_state(), np.random.default_rng(0))
    assert set(cfg.mutation) == {5} and set(cfg.crossover) == {1} and set(cfg.F) == {0.3}
    with pytest.raises(ValueError):
        FixedConfigurator(F=1.5)
    with pytest.raises(ValueError):
        FixedConfigurator("rand/9")


def test_random_covers_the_action_space() -> None:
    cfg = RandomConfigurator().configure(_state(n=2000), np.random.default_rng(1))
    assert set(cfg.mutation) == set(range(7)) and set(cfg.crossover) == {0, 1}
    for a in (cfg.F, cfg.Cr):
        assert 0 <= a.min() < 0.01 and 0.99 < a.max() <= 1
    again = RandomConfigurator().configure(_state(n=2000), np.random.default_rng(1))
    np.testing.assert_array_equal(cfg.F, again.F)


def test_registry() -> None:
    assert isinstance(make_configurator("fixed", F=0.7), FixedConfigurator)
    assert isinstance(make_configurator("random"), RandomConfigurator)
    assert isinstance(make_configurator("adaptive", intensify=0.0), AdaptiveConfigurator)
    with pytest.raises(ValueError):
        make_configurator("learned")


# ---------------------------------------------------------------- adaptive


def test_adaptive_configuration_is_valid() -> None:
    conf = AdaptiveConfigurator()
    state = _state(n=500)
    mem = conf.init(state)
    state = DEState(state.X, state.f, state.phi, state.best, 0, 500, 1000, 0, mem)
    cfg = conf.configure(state, np.random.default_rng(0))
    assert cfg.mutation.min() >= 0 and cfg.mutation.max() <= 6
    assert set(cfg.crossover) <= {0, 1}
    assert cfg.F.min() > 0 and cfg.F.max() <= 1 and cfg.Cr.min() >= 0 and cfg.Cr.max() <= 1
    np.testing.assert_allclose(conf.probabilities(mem).sum(), 1.0)


def test_rank_credit_by_hand() -> None:
    cfg = Config(*(np.zeros(3, int),) * 2, np.full(3, 0.5), np.full(3, 0.5))
    out = Outcome(
        cfg, np.zeros((3, 1)), np.zeros((3, 1)),
        f_parent=np.array([1.0, 2.0, 3.0]), phi_parent=np.array([0.0, 0.0, 1.0]),
        f_trial=np.array([0.5, 1.5, 9.0]), phi_trial=np.array([0.0, 0.0, 0.5]),
        success=np.array([True, True, True]), evaluations=3, budget=9,
    )  # fmt: skip
    # trial 0 beats all three parents, trial 1 beats parents 1 and 2, trial 2 only parent 2
    np.testing.assert_allclose(rank_credit(out), [1.0, 2 / 3, 1 / 3])
    failed = out._replace(success=np.array([False, True, False]))
    np.testing.assert_allclose(rank_credit(failed), [0.0, 2 / 3, 0.0])


@pytest.mark.slow  # measured 5 s (issue 35: default suite <= 5 min)
def test_adaptive_learns_which_arm_and_f_succeed() -> None:
    conf = AdaptiveConfigurator(intensify=0.0)
    mem = conf.init(_state())
    before = conf.probabilities(mem)
    n = 28
    arms = np.arange(n) % len(ARMS)
    F = np.where(arms == 4, 0.8, 0.3)  # arm 4 = rand/2 + bin, always succeeds with F = 0.8
    cfg = Config(ARMS[arms, 0], ARMS[arms, 1], F, np.full(n, 0.5))
    m_f0 = mem.m_f.copy()
    for _ in range(10):
        mem = conf.update(mem, _outcome(cfg, arms == 4))
    after = conf.probabilities(mem)
    assert after[4] > 3 * before[4] and after[4] == after.max()
    assert mem.m_f[4] > 0.6 and np.all(mem.m_f[np.arange(14) != 4] == m_f0[0])
    np.testing.assert_array_equal(m_f0, conf.init(_state()).m_f)  # old memory untouched


def test_adaptive_intensifies_after_a_stall() -> None:
    conf = AdaptiveConfigurator(intensify=0.5, stall_gens=5)
    mem = conf.init(_state())
    cfg = Config(np.zeros(14, int), np.zeros(14, int), np.full(14, 0.5), np.full(14, 0.5))
    p0 = conf.probabilities(mem)[3]
    for _ in range(5):
        mem = conf.update(mem, _outcome(cfg, np.zeros(14, bool)))
    assert mem.stall == 5
    assert conf.probabilities(mem)[3] > 0.5 > p0  # best/1 + exp takes half the draws
    mem = conf.update(mem, _outcome(cfg, np.arange(14) == 0, f_trial=np.full(14, 0.1)))
    assert isinstance(mem, AdaptiveMemory) and mem.stall == 0


def test_configurator_object_is_reusable() -> None:
    p = ConstrainedRastrigin(5)
    conf = AdaptiveConfigurator()
    a = run(p, configurator=conf, seed=4, population=20, budget=600)
    b = run(p, configurator=conf, seed=4, population=20, budget=600)
    np.testing.assert_array_equal(a.state.X, b.state.X)


def test_adaptive_beats_fixed_and_random_on_a_constrained_toy() -> None:
    p = ConstrainedRastrigin(30)
    finals: dict[str, list[float]] = {}
    for name in ("fixed", "random", "adaptive"):
        results = [run(p, configurator=name, seed=s, population=50, budget=5000) for s in range(3)]
        assert all(r.history.feasible_fraction[0] == 0.0 for r in results)
        assert all(r.phi == 0.0 for r in results)
        finals[name] = [r.f for r in results]
    mean = {k: float(np.mean(v)) for k, v in finals.items()}
    assert mean["adaptive"] < 0.7 * min(mean["fixed"], mean["random"]), finals


@pytest.mark.parametrize("seed", range(30))
def test_compiled_update_equals_numpy_reference(seed: int) -> None:
    rng = np.random.default_rng(seed)
    n = int(rng.integers(6, 120))
    k = int(rng.integers(1, n + 1))
    # coarse values so that ties in phi and f (Deb's tie-break) occur often
    f_p, f_t = rng.integers(0, 5, n).astype(float), rng.integers(0, 5, k).astype(float)
    phi_p = np.where(rng.random(n) < 0.5, 0.0, rng.integers(1, 4, n).astype(float))
    phi_t = np.where(rng.random(k) < 0.5, 0.0, rng.integers(1, 4, k).astype(float))
    arm = rng.integers(0, len(ARMS), n)
    cfg = Config(ARMS[arm, 0], ARMS[arm, 1], rng.random(n), rng.random(n))
    out = Outcome(cfg, np.zeros((k, 1)), np.zeros((k, 1)), f_p[:k], phi_p[:k], f_t, phi_t,
                  rng.random(k) < 0.5, k, 10 * n)  # fmt: skip
    conf = AdaptiveConfigurator(rate=float(rng.uniform(0.05, 0.5)), lr=float(rng.random()))
    mem = AdaptiveMemory(rng.random(14), rng.random(14), rng.random(14), int(rng.integers(9)))
    kept = [a.copy() for a in mem[:3]]
    got, ref = conf.update(mem, out), conf.update_reference(mem, out)
    for a, b in zip(got, ref, strict=True):
        assert np.array_equal(a, b)
    for a, b in zip(mem[:3], kept, strict=True):
        assert np.array_equal(a, b)  # the old memory is never written


def test_adaptive_draws_follow_the_arm_probabilities() -> None:
    conf = AdaptiveConfigurator()
    n = 20_000
    state = _state(n=n)
    mem = AdaptiveMemory(np.linspace(0.2, 0.8, 14), np.full(14, 0.5),
                         np.linspace(0.0, 1.0, 14), stall=3)  # fmt: skip
    state = DEState(state.X, state.f, state.phi, state.best, 0, n, 10 * n, 0, mem)
    cfg = conf.configure(state, np.random.default_rng(4))
    arm = cfg.mutation * 2 + cfg.crossover
    freq = np.bincount(arm, minlength=14) / n
    np.testing.assert_allclose(freq, conf.probabilities(mem), atol=0.01)
    for a in (0, 13):  # F centred on the arm's m_f (clipping is rare at sd 0.1)
        assert abs(np.median(cfg.F[arm == a]) - mem.m_f[a]) < 0.02


@pytest.mark.parametrize("seed", range(10))
def test_compiled_configure_equals_numpy_reference(seed: int) -> None:
    rng = np.random.default_rng(seed)
    conf = AdaptiveConfigurator()
    n = int(rng.integers(6, 300))
    q = rng.random(14) * (rng.random(14) < 0.7)  # some arms at zero quality
    mem = AdaptiveMemory(rng.random(14), rng.random(14), q, int(rng.integers(0, 9)))
    state = _state(n=n)
    state = DEState(state.X, state.f, state.phi, state.best, 0, n, 10 * n, 0, mem)
    got = conf.configure(state, np.random.default_rng(seed))
    ref = conf.configure_reference(state, np.random.default_rng(seed))
    for a, b in zip(got, ref, strict=True):
        assert np.array_equal(a, b)
