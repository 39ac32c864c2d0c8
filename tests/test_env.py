"""The optimisation MDP: observation encoding and shapes, reward cases, determinism, episode end."""

from __future__ import annotations

import math

import numpy as np
import pytest

from planner_core.learning.env import OptimizationEnv, mantissa_exponent, observe, reward
from planner_core.search.de import Config


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
    assert set(obs) == {"X", "f", "phi", "progress", "context"}
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


# ---------------------------------------------------------------- Gymnasium


@pytest.fixture(scope="module")
def suite_problem():
    from planner_core.model.problem import Problem
    from tests.conftest import SUITE

    return Problem(SUITE / "T01.json")


def test_check_env_passes_on_a_suite_map(suite_problem) -> None:
    import warnings

    import gymnasium
    from gymnasium.utils.env_checker import check_env

    from planner_core.learning.env import ENV_ID

    assert isinstance(OptimizationEnv(suite_problem), gymnasium.Env)
    env = gymnasium.make(ENV_ID, problem=suite_problem, population=8, budget=8 * 6).unwrapped
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        check_env(env)
    gym_warnings = [str(w.message) for w in caught if "gymnasium" in w.filename]
    assert gym_warnings == []
    # the declared spaces fit this problem and population, and hold what the env returns
    obs, _ = env.reset(seed=0)
    assert env.observation_space["X"].shape == (8, suite_problem.dim)
    assert env.action_space["mutation"].shape == (8,)
    assert env.observation_space.contains(obs)
    obs, r, terminated, truncated, _ = env.step(env.action_space.sample())
    assert env.observation_space.contains(obs) and isinstance(r, float)
    assert terminated is False and truncated is False


def test_spaces_follow_the_problem_and_population_at_reset() -> None:
    env = OptimizationEnv(ShiftedBall(3), population=10, budget=100)
    assert env.observation_space["X"].shape == (10, 3)
    env.reset(seed=0, options={"problem": ShiftedBall(5), "population": 14})
    assert env.observation_space["X"].shape == (14, 5)
    assert env.observation_space["f"].shape == (14, 2)
    assert env.action_space["F"].shape == (14,) and env.action_space["crossover"].shape == (14,)
    assert not hasattr(OptimizationEnv(), "observation_space")  # no problem, no spaces yet


def test_seeding_goes_through_np_random() -> None:
    env = OptimizationEnv(ShiftedBall(3), population=10, budget=100)
    env.reset(seed=11)
    expected = np.random.default_rng(11)  # the streams the env had before it was a gymnasium.Env
    assert env.state.seed == int(expected.integers(0, 2**63 - 1))
    env.reset()  # the next episode continues the seeded stream
    assert env.state.seed == int(expected.integers(0, 2**63 - 1))
    assert env.np_random_seed == 11


def test_reset_names_a_bad_population() -> None:
    env = OptimizationEnv(ShiftedBall(2))
    with pytest.raises(ValueError, match="^population: "):
        env.reset(seed=0, options={"population": 5, "budget": 50})
    with pytest.raises(ValueError, match="^budget: "):
        env.reset(seed=0, options={"population": 10, "budget": 9})


def test_vector_env_steps_every_copy() -> None:
    import gymnasium

    from planner_core.learning.env import ENV_ID

    vec = gymnasium.make_vec(ENV_ID, num_envs=2, vectorization_mode="sync",
                             problem=ShiftedBall(3), population=10, budget=60)
    obs, _ = vec.reset(seed=[1, 2])
    assert obs["X"].shape == (2, 10, 3)
    obs, r, term, trunc, _ = vec.step(vec.action_space.sample())
    assert r.shape == (2,) and not term.any() and not trunc.any()
    vec.close()
