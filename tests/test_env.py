"""The optimisation MDP: observation encoding and shapes, reward cases, determinism, episode end."""

from __future__ import annotations

import math

import numpy as np
import pytest

from planner_core.de import Config
from planner_core.env import OptimizationEnv, mantissa_exponent, observe, reward


class ShiftedBall:
    """min sum(x) on [-1, 2]^d s.t. ||x - 1|| <= 0.5: infeasible at first, f may be negative."""

    def __init__(self, d: int) -> None:
        self.lower = np.full(d, -1.0)
        self.upper = np.full(d, 2.0)

    def evaluate(self, X: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        return X.sum(axis=1), np.maximum(np.linalg.norm(X - 1.0, axis=1) - 0.5, 0.0)


def _actions(n: int, steps: int, seed: int = 0) -> list[Config]:
    rng = np.random.default_rng(seed)
    return [
        Config(rng.integers(0, 7, n), rng.integers(0, 2, n), rng.random(n), rng.random(n))
        for _ in range(steps)
    ]


# ---------------------------------------------------------------- observation


def test_mantissa_exponent_by_hand() -> None:
    y = np.array([1234.0, -0.05, 0.0, 1000.0, 1e-8, 0.999, -7.0, np.inf])
    enc = mantissa_exponent(y, eta=10.0)
    np.testing.assert_allclose(enc[:, 0], [0.1234, -0.5, 0.0, 0.1, 0.1, 0.999, -0.7, 1.0])
    np.testing.assert_allclose(enc[:, 1], [0.4, -0.1, 0.0, 0.4, -0.7, 0.0, 0.1, 40.0])
    finite = np.isfinite(y) & (y != 0)
    back = enc[finite, 0] * 10.0 ** np.round(enc[finite, 1] * 10)
    np.testing.assert_allclose(back, y[finite])
    # |omega| in [0.1, 1) even at awkward powers of ten
    tricky = 10.0 ** np.arange(-12, 13) * np.array([[1.0], [0.9999999999999999], [1.0000000001]])
    om = np.abs(mantissa_exponent(tricky)[..., 0])
    assert om.min() >= 0.1 and om.max() < 1.0


@pytest.mark.parametrize(("n", "d"), [(10, 3), (24, 7)])
def test_observation_shapes(n: int, d: int) -> None:
    env = OptimizationEnv(population=n, budget=5 * n)
    obs, info = env.reset(seed=0, options={"problem": ShiftedBall(d)})
    assert set(obs) == {"X", "f", "phi", "progress"}
    assert obs["X"].shape == (n, d) and obs["f"].shape == (n, 2) and obs["phi"].shape == (n, 2)
    assert obs["progress"].shape == (1,) and obs["progress"][0] == 0.0
    assert 0.0 <= obs["X"].min() and obs["X"].max() <= 1.0
    assert info["evaluations"] == n and info["generation"] == 0
    np.testing.assert_array_equal(obs["X"], observe(env.state)["X"])


# ---------------------------------------------------------------- reward


def test_reward_cases_by_hand() -> None:
    d = 1e-8
    # 1. still infeasible: relative violation decrease
    assert reward(4.0, 10.0, 3.0, 99.0, 0.3, d) == pytest.approx(0.25)
    assert reward(4.0, 10.0, 4.0, 1.0, 0.3, d) == 0.0
    # 2. entering the feasible region: 1 + exp(-g/G), at any tolerance-feasible phi
    assert reward(4.0, 10.0, 0.0, 99.0, 0.5, d) == pytest.approx(1 + math.exp(-0.5))
    assert reward(4.0, 10.0, 5e-9, 99.0, 1.0, d) == pytest.approx(1 + math.exp(-1.0))
    # 3. feasible before and after: relative objective decrease, |f| in the denominator
    assert reward(0.0, 10.0, 0.0, 8.0, 0.5, d) == pytest.approx(0.2)
    assert reward(0.0, -10.0, 0.0, -12.0, 0.5, d) == pytest.approx(0.2)
    assert reward(1e-9, 10.0, 0.0, 10.0, 0.5, d) == 0.0
    # guards: zero denominators give 0
    assert reward(0.0, 0.0, 0.0, -1.0, 0.5, d) == 0.0
    assert reward(0.0, 1.0, 2.0, 1.0, 0.5, d) == 0.0  # phi_prev = 0 (cannot happen under Deb)
    assert reward(math.inf, 1.0, 2.0, 1.0, 0.5, d) == 0.0  # broken evaluations read as inf


# ---------------------------------------------------------------- episodes


def _rollout(seed: int, actions: list[Config]) -> tuple[list[dict], list[float], list[bool]]:
    env = OptimizationEnv(ShiftedBall(4), population=12, budget=12 * 8)
    obs, _ = env.reset(seed=seed)
    observations, rewards, dones = [obs], [], []
    for a in actions:
        obs, r, terminated, truncated, _ = env.step(a)
        assert truncated is False
        observations.append(obs)
        rewards.append(r)
        dones.append(terminated)
    return observations, rewards, dones


def test_same_seed_same_actions_is_deterministic() -> None:
    acts = _actions(12, 7)
    o1, r1, d1 = _rollout(5, acts)
    o2, r2, d2 = _rollout(5, acts)
    assert r1 == r2 and d1 == d2
    for a, b in zip(o1, o2, strict=True):
        for key in a:
            np.testing.assert_array_equal(a[key], b[key])
    o3, _, _ = _rollout(6, acts)
    assert not np.array_equal(o1[0]["X"], o3[0]["X"])


def test_episode_runs_to_the_budget_and_rewards_match_the_pure_function() -> None:
    env = OptimizationEnv(population=12, budget=12 * 8 + 5)
    _, info = env.reset(seed=1, options={"problem": ShiftedBall(3)})
    prev = info
    G = env.state.max_generations
    acts = _actions(12, 20, seed=3)
    steps = 0
    for a in acts:
        as_dict = {"mutation": a.mutation, "crossover": a.crossover, "F": a.F, "Cr": a.Cr}
        obs, r, terminated, truncated, info = env.step(as_dict if steps % 2 else tuple(a))
        steps += 1
        expected = reward(prev["best_phi"], prev["best_f"], info["best_phi"], info["best_f"],
                          info["generation"] / G)  # fmt: skip
        assert r == expected
        prev = info
        if terminated:
            break
    assert steps == G == 8 and info["evaluations"] == 12 * 8 + 5 and obs["progress"][0] == 1.0
    with pytest.raises(RuntimeError):
        env.step(acts[0])


def test_reset_needs_a_problem_and_valid_actions() -> None:
    env = OptimizationEnv()
    with pytest.raises(ValueError):
        env.reset(seed=0)
    with pytest.raises(RuntimeError):
        env.step(_actions(10, 1)[0])
    env.reset(seed=0, options={"problem": ShiftedBall(2), "population": 10, "budget": 50})
    with pytest.raises(ValueError):
        env.step(_actions(9, 1)[0])  # wrong population size
