"""Per-individual credit (issue 34): the env's trial credit, the learner's advantages, the
context features, and the diagnostic that the per-individual signal is detectable."""

from __future__ import annotations

import numpy as np
import pytest

from planner_core.learning.env import (
    FEATURE_RATE,
    N_ARMS,
    N_CONTEXT,
    SUCCESS_PRIOR,
    OptimizationEnv,
    initial_features,
    trial_credit,
    update_features,
)
from planner_core.learning.policy.credit import (
    credit_signal,
    individual_advantages,
    record_generations,
    slope_t,
)


def test_trial_credit_by_hand() -> None:
    # parents: infeasible (phi 4), infeasible, feasible f 100, feasible f 100, feasible f -50
    fp = np.array([10.0, 10.0, 100.0, 100.0, -50.0])
    pp = np.array([4.0, 4.0, 0.0, 0.0, 0.0])
    ft = np.array([99.0, 5.0, 90.0, 101.0, -60.0])
    pt = np.array([1.0, 0.0, 0.0, 0.0, 0.0])
    c = trial_credit(fp, pp, ft, pt)
    # violation 4 -> 1: 1 + 0.75; 4 -> feasible: 2; f 100 -> 90: 0.1; worse: 0; -50 -> -60: 0.2
    np.testing.assert_allclose(c, [1.75, 2.0, 0.1, 0.0, 0.2])
    # a worse violation or an infeasible trial of a feasible parent earns nothing
    assert trial_credit([1.0, 1.0], [2.0, 0.0], [0.5, 0.5], [3.0, 1e-3]).tolist() == [0.0, 0.0]


def test_individual_advantages_are_standardised_within_parent_class() -> None:
    credit = np.array([[1.5, 1.0, 2.0, 0.01, 0.03, 0.02]])
    feas = np.array([[False, False, False, True, True, True]])
    adv = individual_advantages(credit, feas)
    for cls in (~feas[0], feas[0]):
        assert abs(adv[0, cls].mean()) < 1e-12 and abs(adv[0, cls].std() - 1.0) < 1e-12
    # the order within a class follows the credit; no spread or a single member gives 0
    assert adv[0, 4] > adv[0, 5] > adv[0, 3]
    assert individual_advantages(np.array([0.3, 0.3]), np.array([True, True])).tolist() == [0, 0]
    assert individual_advantages(np.array([0.3, 1.2]), np.array([True, False])).tolist() == [0, 0]


def test_feature_memory_update_by_hand() -> None:
    mem = initial_features()
    assert mem.arm_success.shape == (N_ARMS,) and mem.stall == 0
    # arm 2*1 + 0 = 2 used twice, one success; arm 2*3 + 1 = 7 once, success; no improvement
    nxt = update_features(mem, np.array([1, 1, 3]), np.array([0, 0, 1]),
                          np.array([True, False, True]), improved=False)
    want = np.full(N_ARMS, SUCCESS_PRIOR)
    want[2] += FEATURE_RATE * (0.5 - SUCCESS_PRIOR)
    want[7] += FEATURE_RATE * (1.0 - SUCCESS_PRIOR)
    np.testing.assert_allclose(nxt.arm_success, want)
    assert nxt.stall == 1 and mem.arm_success[2] == SUCCESS_PRIOR  # not mutated
    assert update_features(nxt, np.array([0]), np.array([0]), np.array([False]), True).stall == 0


def test_env_reports_credit_and_context() -> None:
    from planner_core.model.problem import Problem
    from tests.conftest import SUITE

    env = OptimizationEnv(Problem(SUITE / "T01.json"), population=20, budget=200)
    obs, _ = env.reset(seed=3)
    assert obs["context"].shape == (N_CONTEXT,)
    rng = np.random.default_rng(0)
    for _ in range(3):
        a = (rng.integers(0, 7, 20), rng.integers(0, 2, 20), rng.random(20), rng.random(20))
        parents = (env.state.f.copy(), env.state.phi.copy())
        obs, _, _, _, info = env.step(a)
        assert info["credit"].shape == (20,) and info["parent_feasible"].shape == (20,)
        # an individual earns credit exactly when its trial replaced its parent
        replaced = (env.state.f != parents[0]) | (env.state.phi != parents[1])
        np.testing.assert_array_equal(info["credit"] > 0, replaced)
        assert 0.0 <= obs["context"].min() and obs["context"].max() <= 1.0
    assert env.observation_space.contains(obs)


def test_slope_t_by_hand() -> None:
    x = np.arange(10.0)
    assert slope_t(2 * x + np.array([0.1, -0.1] * 5), x) > 50
    assert slope_t(np.ones(10), x) == 0.0


# ~1 s (measured): one DE run of 10,000 evaluations on a generated map
def test_own_action_is_detectable_with_individual_credit_not_with_shared_reward() -> None:
    from planner_core.model.problem import Problem
    from planner_core.suite import generate_map

    problem = Problem(generate_map(5000, 2, 7000))
    rec = record_generations(problem, seed=0, population=100, budget=10000)
    sig = credit_signal(rec)
    # the finding on a small fixed-seed run: the individual's F is detectable from its
    # own credit (measured t -7.1), not from the generation's shared reward (measured t 1.7)
    assert sig["individual"]["F"] < -4.0
    assert abs(sig["shared"]["F"]) < 2.0
    assert max(abs(v) for v in sig["individual"].values()) > 2 * max(
        abs(v) for v in sig["shared"].values())


# ---------------------------------------------------------------- the network's context

def _obs_with_context(n: int, d: int, seed: int) -> dict[str, np.ndarray]:
    from planner_core.learning.env import mantissa_exponent

    rng = np.random.default_rng(seed)
    return {"X": rng.random((n, d)), "f": mantissa_exponent(rng.lognormal(5.0, 2.0, n)),
            "phi": mantissa_exponent(np.where(rng.random(n) < 0.5, 0.0, rng.random(n))),
            "progress": np.array([rng.random()]), "context": rng.random(N_CONTEXT)}


def _random_params(cfg, seed: int) -> dict[str, np.ndarray]:  # noqa: ANN001
    from planner_core.learning.policy.network import param_shapes

    rng = np.random.default_rng(seed)
    return {k: rng.normal(0.0, 0.5, s).astype(np.float32) for k, s in param_shapes(cfg).items()}


@pytest.mark.slow  # 7.7 s measured (torch's import in a fresh process)
def test_context_network_numpy_equals_torch_and_widening_changes_nothing() -> None:
    torch = pytest.importorskip("torch")
    from planner_core.learning.policy.network import NetConfig, forward
    from planner_core.learning.policy.ppo import TorchPolicy, batch_obs, with_context

    narrow, wide = NetConfig(embed=8, heads=2, ff=12, hidden=10), NetConfig(
        embed=8, heads=2, ff=12, hidden=10, context=N_CONTEXT)
    obs = _obs_with_context(9, 5, 1)
    params = _random_params(wide, 2)
    ref = forward(params, wide, obs)
    model = TorchPolicy(wide)
    model.load_numpy(params)
    o = batch_obs([obs])
    with torch.no_grad():
        mut, _, F_ab, _, value = model(o["X"], o["f"], o["phi"], o["progress"], o["mask"],
                                       o["context"])
    np.testing.assert_allclose(mut[0].numpy(), ref.mutation_logits, atol=1e-5, rtol=1e-5)
    np.testing.assert_allclose(F_ab[0].numpy(), ref.F_ab, atol=1e-5, rtol=1e-5)
    assert abs(float(value[0]) - ref.value) < 1e-5
    # a network without context, widened with zero rows, computes exactly what it did
    small = _random_params(narrow, 3)
    a, b = forward(small, narrow, obs), forward(with_context(small, narrow, wide), wide, obs)
    np.testing.assert_array_equal(a.mutation_logits, b.mutation_logits)
    assert a.value == b.value
    with pytest.raises(ValueError, match="context"):
        NetConfig(context=3)
    with pytest.raises(ValueError, match="context"):
        forward(params, wide, {k: v for k, v in obs.items() if k != "context"})


@pytest.mark.slow  # measured 2.8 s on a loaded machine (issue 35: default suite <= 5 min)
def test_old_checkpoint_reads_without_context_and_keeps_no_memory() -> None:
    from planner_core.learning.policy import PolicyConfigurator, load
    from planner_core.learning.policy.ppo import PPOConfig

    params, net, config = load("lamde-v2")
    assert net.context == 0 and params["join.weight"].shape[0] == net.embed + 1
    # its stored training settings read as the shared credit it was trained with
    assert PPOConfig.from_dict(config["training"]["ppo"]).credit == "shared"
    assert PPOConfig().credit == "individual" and PPOConfig().net.context == N_CONTEXT
    assert PolicyConfigurator("lamde-v2").init(None) is None  # type: ignore[arg-type]


@pytest.mark.slow  # 11.3 s measured: three one-epoch trainings
def test_individual_credit_training_smoke(tmp_path) -> None:  # noqa: ANN001
    import json

    pytest.importorskip("torch")
    from planner_core.learning.policy import load
    from planner_core.learning.policy.network import NetConfig
    from planner_core.learning.policy.ppo import PPOConfig, train
    from tests.conftest import HAND_MAP, MAPS

    specs = [{"kind": "map", "path": str(MAPS / "tiny.json")}, {"kind": "map", "map": HAND_MAP}]
    net = NetConfig(embed=8, heads=2, ff=12, hidden=10, context=N_CONTEXT)
    cfg = PPOConfig(epochs=1, envs=2, population=8, budget=64, n_steps=3, net=net,
                    imitate="none", reward_scale=False)
    out = train(cfg, specs, tmp_path / "a")
    params, got, config = load(out)
    assert got == net and config["training"]["ppo"]["credit"] == "individual"
    again = train(cfg, specs, tmp_path / "b")
    assert (again / "weights.npz").read_bytes() == (out / "weights.npz").read_bytes()
    # the shared mode trains another policy from the same seed
    train(PPOConfig(**{**cfg.__dict__, "credit": "shared"}), specs, tmp_path / "c")
    assert (tmp_path / "c" / "weights.npz").read_bytes() != (out / "weights.npz").read_bytes()
    assert json.loads((tmp_path / "c" / "config.json").read_text())["training"]["ppo"][
        "credit"] == "shared"
    with pytest.raises(ValueError, match="credit"):
        train(PPOConfig(**{**cfg.__dict__, "credit": "mine"}), specs, tmp_path / "d")


@pytest.mark.slow  # measured 10.6 s under a load of 4 (a DE run recorded, its regressions)
def test_the_credit_diagnostic_cli_prints_both_signals(capsys) -> None:  # noqa: ANN001
    """`python -m planner_core.learning.policy.credit` (docs/learning.md): one line per effect
    with its t under per-individual credit and under the shared reward; a small run."""
    from planner_core.learning.policy import credit

    credit.main(["--budget", "2000", "--population", "40"])
    out = capsys.readouterr().out
    assert out.splitlines()[0].endswith("generations x 40 individuals")
    rows = [ln for ln in out.splitlines() if "t individual" in ln and "t shared" in ln]
    assert any(ln.split()[0] == "F" for ln in rows), out
