"""The learned meta-level: network shapes and exact log-probabilities, numpy == torch, PPO update,
a 2-epoch training smoke run, checkpoint I/O and deterministic planning with a checkpoint."""

from __future__ import annotations

import json
import math
import sys

import numpy as np
import pytest
from scipy.special import betaln, log_softmax

from planner_core.learning.env import mantissa_exponent
from planner_core.learning.policy import (
    CheckpointError,
    NetConfig,
    PolicyConfigurator,
    forward,
    init_params,
    load,
    log_prob,
    mode_actions,
    param_count,
    sample_actions,
    save,
)
from planner_core.learning.policy.network import param_shapes
from planner_core.learning.policy.problems import (
    TRAIN_SEED_BASE,
    VALIDATION_SEED_BASE,
    default_training_specs,
    read_trainset,
    validation_specs,
)
from planner_core.model.problem import Problem
from planner_core.search.de import run
from planner_core.search.init_modes import UniformStart, with_init
from planner_core.suite import SUITE_SEED
from tests.conftest import HAND_MAP, MAPS

NET = NetConfig(embed=8, heads=2, ff=12, hidden=10)


def _random_params(cfg: NetConfig, seed: int) -> dict[str, np.ndarray]:
    """Weights with every head non-zero (init_params zeroes the actor heads)."""
    rng = np.random.default_rng(seed)
    return {k: rng.normal(0.0, 0.5, s).astype(np.float32) for k, s in param_shapes(cfg).items()}


def _random_obs(n: int, d: int, seed: int) -> dict[str, np.ndarray]:
    rng = np.random.default_rng(seed)
    f = rng.lognormal(5.0, 2.0, n)
    phi = np.where(rng.random(n) < 0.5, 0.0, rng.lognormal(0.0, 3.0, n))
    return {"X": rng.random((n, d)), "f": mantissa_exponent(f), "phi": mantissa_exponent(phi),
            "progress": np.array([rng.random()])}


@pytest.mark.parametrize("n", [6, 11])
@pytest.mark.parametrize("d", [3, 8])
def test_action_shapes_and_exact_log_prob(n: int, d: int) -> None:
    params = _random_params(NET, 1)
    out = forward(params, NET, _random_obs(n, d, 2))
    assert out.mutation_logits.shape == (n, 7) and out.crossover_logits.shape == (n, 2)
    assert out.F_ab.shape == (n, 2) and out.Cr_ab.shape == (n, 2)
    assert (out.F_ab > 1).all() and (out.Cr_ab > 1).all() and math.isfinite(out.value)
    mut, cx, F, Cr = sample_actions(out, np.random.default_rng(3))
    for a, lo, hi in ((mut, 0, 6), (cx, 0, 1), (F, 0, 1), (Cr, 0, 1)):
        assert a.shape == (n,) and a.min() >= lo and a.max() <= hi
    assert mut.dtype == np.intp and cx.dtype == np.intp
    # the log-probability by hand: log-softmax of the logits + the Beta log-density
    # log x^(a-1) (1-x)^(b-1) / B(a, b), nothing clamped
    def beta_lp(x: np.ndarray, ab: np.ndarray) -> np.ndarray:
        a, b = ab[:, 0], ab[:, 1]
        return (a - 1) * np.log(x) + (b - 1) * np.log1p(-x) - betaln(a, b)

    rows = np.arange(n)
    by_hand = (log_softmax(out.mutation_logits, axis=1)[rows, mut]
               + log_softmax(out.crossover_logits, axis=1)[rows, cx]
               + beta_lp(F, out.F_ab) + beta_lp(Cr, out.Cr_ab))
    np.testing.assert_allclose(log_prob(out, mut, cx, F, Cr), by_hand, rtol=1e-12)
    torch = pytest.importorskip("torch")
    from planner_core.learning.policy.ppo import TorchPolicy, batch_obs, log_prob_entropy

    model = TorchPolicy(NET).double()
    model.load_numpy(params)
    o = {k: v.double() if v.is_floating_point() else v
         for k, v in batch_obs([_random_obs(n, d, 2)]).items()}
    o["X"] = torch.from_numpy(_random_obs(n, d, 2)["X"])[None]
    t_out = model(o["X"], o["f"], o["phi"], o["progress"], o["mask"])
    acts = torch.from_numpy(np.stack([mut, cx, F, Cr], axis=1))[None]
    lp, ent = log_prob_entropy(t_out, acts)
    np.testing.assert_allclose(lp[0].detach().numpy(), by_hand, rtol=1e-6, atol=1e-6)
    assert ent.shape == (1, n)


def test_mode_actions_are_the_distributions_modes() -> None:
    out = forward(_random_params(NET, 4), NET, _random_obs(9, 5, 5))
    mut, cx, F, Cr = mode_actions(out)
    np.testing.assert_array_equal(mut, out.mutation_logits.argmax(axis=1))
    a, b = out.F_ab[:, 0], out.F_ab[:, 1]
    grid = np.linspace(1e-4, 1 - 1e-4, 20001)
    dens = (a[:, None] - 1) * np.log(grid) + (b[:, None] - 1) * np.log1p(-grid)
    np.testing.assert_allclose(F, grid[dens.argmax(axis=1)], atol=1e-4)
    assert cx.shape == Cr.shape == (9,)


@pytest.mark.parametrize("n,d", [(7, 4), (30, 40)])
def test_numpy_forward_equals_torch(n: int, d: int) -> None:
    torch = pytest.importorskip("torch")
    from planner_core.learning.policy.ppo import TorchPolicy, batch_obs

    cfg = NetConfig()
    params = _random_params(cfg, 7)
    obs = _random_obs(n, d, 8)
    ref = forward(params, cfg, obs)
    model = TorchPolicy(cfg)
    model.load_numpy(params)
    o = batch_obs([obs])
    with torch.no_grad():
        mut, cx, F_ab, Cr_ab, value = model(o["X"], o["f"], o["phi"], o["progress"], o["mask"])
    for got, want in ((mut, ref.mutation_logits), (cx, ref.crossover_logits),
                      (F_ab, ref.F_ab), (Cr_ab, ref.Cr_ab)):
        np.testing.assert_allclose(got[0].numpy(), want, atol=1e-5, rtol=1e-5)
    assert abs(float(value[0]) - ref.value) < 1e-5


def test_padded_batch_equals_each_problem_alone() -> None:
    """Problems of different dimension share one forward pass (padding is masked)."""
    torch = pytest.importorskip("torch")
    from planner_core.learning.policy.ppo import TorchPolicy, batch_obs

    cfg = NetConfig()
    params = _random_params(cfg, 9)
    model = TorchPolicy(cfg)
    model.load_numpy(params)
    obs = [_random_obs(6, 3, 10), _random_obs(6, 9, 11)]
    o = batch_obs(obs)
    with torch.no_grad():
        batched = model(o["X"], o["f"], o["phi"], o["progress"], o["mask"])
    for b, ob in enumerate(obs):
        ref = forward(params, cfg, ob)
        np.testing.assert_allclose(batched[0][b].numpy(), ref.mutation_logits, atol=1e-5)
        np.testing.assert_allclose(batched[2][b].numpy(), ref.F_ab, atol=1e-5)
        assert abs(float(batched[4][b]) - ref.value) < 1e-5


@pytest.mark.slow  # 4.5 s measured in the default suite
def test_one_ppo_update_lowers_the_clipped_loss() -> None:
    torch = pytest.importorskip("torch")
    from planner_core.learning.policy.ppo import (
        PPOConfig,
        TorchPolicy,
        _cat_obs,
        batch_obs,
        clipped_objective,
        log_prob_entropy,
        ppo_update,
    )

    torch.manual_seed(0)
    # the clipped surrogate alone (the value and entropy terms share the trunk and may pull the
    # first step elsewhere): one small Adam step must lower it
    cfg = PPOConfig(update_epochs=1, lr=1e-3, net=NET, norm_adv=False, vf_coef=0.0, ent_coef=0.0)
    model = TorchPolicy(NET)
    model.load_numpy(_random_params(NET, 12))
    obs = _cat_obs([batch_obs([_random_obs(8, 5, s)]) for s in range(6)])
    rng = np.random.default_rng(13)
    acts = torch.from_numpy(np.stack([rng.integers(0, 7, (6, 8)), rng.integers(0, 2, (6, 8)),
                                      rng.uniform(0.05, 0.95, (6, 8)),
                                      rng.uniform(0.05, 0.95, (6, 8))], axis=-1)).float()
    with torch.no_grad():
        out = model(obs["X"], obs["f"], obs["phi"], obs["progress"], obs["mask"])
        old_logp, _ = log_prob_entropy(out, acts)
    adv = torch.from_numpy(rng.normal(size=6).astype(np.float32))
    before = clipped_objective(model, cfg, obs, acts, old_logp, adv)
    opt = torch.optim.Adam(model.parameters(), lr=cfg.lr)
    stats = ppo_update(model, opt, cfg, obs, acts, old_logp, adv, out[4] + adv)
    after = clipped_objective(model, cfg, obs, acts, old_logp, adv)
    assert after < before
    assert set(stats) == {"policy_loss", "value_loss", "entropy", "approx_kl", "clipfrac",
                          "bc_kl"}


@pytest.mark.slow  # 4.2 s measured in the default suite
def test_bc_anchor_kl_is_exact_and_holds_ppo_near_the_reference() -> None:
    """KL(pi_ref || pi) of the factorised policy equals E_ref[log pi_ref - log pi] (checked by
    Monte Carlo on the exact log-probabilities), is 0 against itself, and the anchor in the PPO
    loss keeps the updated policy closer to the reference than plain PPO on the same batch."""
    torch = pytest.importorskip("torch")
    from planner_core.learning.policy.ppo import (
        PPOConfig,
        TorchPolicy,
        _cat_obs,
        batch_obs,
        kl_from_reference,
        log_prob_entropy,
        ppo_update,
    )

    ref, other = TorchPolicy(NET), TorchPolicy(NET)
    ref.load_numpy(_random_params(NET, 21))
    other.load_numpy(_random_params(NET, 22))
    obs = _cat_obs([batch_obs([_random_obs(5, 4, s)]) for s in range(3)])
    with torch.no_grad():
        ro = ref(obs["X"], obs["f"], obs["phi"], obs["progress"], obs["mask"])
        oo = other(obs["X"], obs["f"], obs["phi"], obs["progress"], obs["mask"])
        assert float(kl_from_reference(ro, ro).abs().max()) < 1e-5
        kl = kl_from_reference(ro, oo)  # (3, 5)
        assert kl.shape == (3, 5) and bool((kl > 0).all())
        # Monte Carlo: sample the reference's actions, average the log-ratio
        torch.manual_seed(3)
        S = 40_000
        Fd = torch.distributions.Beta(ro[2][..., 0], ro[2][..., 1])
        Cd = torch.distributions.Beta(ro[3][..., 0], ro[3][..., 1])
        acts = torch.stack([torch.distributions.Categorical(logits=ro[0]).sample((S,)).float(),
                            torch.distributions.Categorical(logits=ro[1]).sample((S,)).float(),
                            Fd.sample((S,)).clamp(1e-6, 1 - 1e-6),
                            Cd.sample((S,)).clamp(1e-6, 1 - 1e-6)], dim=-1)  # (S, 3, 5, 4)
        rep = [t.expand(S, *t.shape) for t in ro]
        orep = [t.expand(S, *t.shape) for t in oo]
        lp_ref, _ = log_prob_entropy(rep, acts)
        lp_oth, _ = log_prob_entropy(orep, acts)
        mc = (lp_ref - lp_oth).mean(dim=0)
        se = (lp_ref - lp_oth).std(dim=0) / math.sqrt(S)
    assert bool(((mc - kl).abs() < 5 * se + 1e-3).all())

    # the anchor: same batch, same start, several PPO steps with and without it
    rng = np.random.default_rng(5)
    acts = torch.from_numpy(np.stack([rng.integers(0, 7, (3, 5)), rng.integers(0, 2, (3, 5)),
                                      rng.uniform(0.05, 0.95, (3, 5)),
                                      rng.uniform(0.05, 0.95, (3, 5))], axis=-1)).float()
    with torch.no_grad():
        old_logp, _ = log_prob_entropy(ro, acts)
    adv = torch.from_numpy(rng.normal(size=3).astype(np.float32))
    cfg = PPOConfig(update_epochs=20, lr=1e-2, clip=10.0, net=NET, vf_coef=0.0, ent_coef=0.0)
    kls = []
    for coef in (0.0, 10.0):
        model = TorchPolicy(NET)
        model.load_numpy(ref.numpy_params())
        opt = torch.optim.Adam(model.parameters(), lr=cfg.lr)
        stats = ppo_update(model, opt, cfg, obs, acts, old_logp, adv, ro[4], ref, coef)
        with torch.no_grad():
            out = model(obs["X"], obs["f"], obs["phi"], obs["progress"], obs["mask"])
            kls.append(float(kl_from_reference(ro, out).mean()))
        assert "bc_kl" in stats
    assert 0 < kls[1] < 0.5 * kls[0]


def test_gae_by_hand() -> None:
    pytest.importorskip("torch")
    from planner_core.learning.policy.ppo import gae

    r = np.array([[1.0], [2.0]])
    v = np.array([[0.5], [0.25]])
    adv = gae(r, v, np.array([[0.0], [0.0]]), np.array([4.0]), gamma=0.5, lam=0.5)
    d1 = 2.0 + 0.5 * 4.0 - 0.25
    d0 = 1.0 + 0.5 * 0.25 - 0.5
    np.testing.assert_allclose(adv[:, 0], [d0 + 0.25 * d1, d1])
    adv = gae(r, v, np.array([[0.0], [1.0]]), np.array([4.0]), gamma=0.5, lam=0.5)
    assert adv[1, 0] == 2.0 - 0.25  # terminal: nothing bootstrapped


TINY_SPECS = [{"kind": "map", "path": str(MAPS / "tiny.json")}, {"kind": "map", "map": HAND_MAP}]


def _tiny_cfg(**kw):  # noqa: ANN202
    from planner_core.learning.policy.ppo import PPOConfig

    base = {"epochs": 2, "envs": 2, "population": 8, "budget": 64, "n_steps": 3, "net": NET,
            "imitate": "adaptive", "imitate_epochs": 2, "imitate_stride": 2}
    return PPOConfig(**{**base, **kw})


@pytest.mark.slow  # measured 4.3 s on a loaded machine (default suite <= 5 min)
def test_two_epoch_training_smoke_run_and_resume(tmp_path) -> None:  # noqa: ANN001
    pytest.importorskip("torch")
    from planner_core.learning.policy.ppo import CURVE_FIELDS, train

    lines: list[str] = []
    out = train(_tiny_cfg(), TINY_SPECS, tmp_path / "a", log=lines.append)
    assert sum(line.startswith("epoch ") for line in lines) == 2
    assert sum(line.startswith("imitation epoch ") for line in lines) == 2
    curve = (out / "curve.csv").read_text().splitlines()
    assert curve[0].split(",") == list(CURVE_FIELDS) and len(curve) == 3
    manifest = json.loads((out / "manifest.json").read_text())
    assert manifest["problems"] == TINY_SPECS
    params, net, config = load(out)
    assert net == NET and config["training"]["epochs_done"] == 2
    assert [r["epoch"] for r in config["training"]["imitation"]] == [1, 2]
    # same seed, same checkpoint; 1 epoch + resume to 2 epochs gives the same weights too
    again = train(_tiny_cfg(), TINY_SPECS, tmp_path / "b")
    assert (again / "weights.npz").read_bytes() == (out / "weights.npz").read_bytes()
    train(_tiny_cfg(epochs=1), TINY_SPECS, tmp_path / "c")
    train(_tiny_cfg(), TINY_SPECS, tmp_path / "c", resume=True)
    assert (tmp_path / "c" / "weights.npz").read_bytes() == (out / "weights.npz").read_bytes()
    with pytest.raises(ValueError, match="resume"):
        train(_tiny_cfg(lr=0.5), TINY_SPECS, tmp_path / "c", resume=True)


@pytest.mark.slow  # measured 1.7 s on a loaded machine (default suite <= 5 min)
def test_ppo_from_a_checkpoint_with_the_bc_anchor_resumes_exactly(tmp_path) -> None:  # noqa: ANN001
    """init_checkpoint starts PPO from given weights (the epoch-0 checkpoint is those weights,
    no imitation fit); the anchor's reference survives --resume (1 + 1 epochs == 2 epochs); a
    checkpoint of another network size is refused."""
    pytest.importorskip("torch")
    from planner_core.learning.policy.ppo import train

    said: list[str] = []  # --resume on a folder with no training (a typo) says so
    bc = train(_tiny_cfg(epochs=0), TINY_SPECS, tmp_path / "bc", resume=True, log=said.append)
    assert any("holds no training to continue (no state.pt): starting one" in s for s in said)
    kw = {"init_checkpoint": str(bc), "bc_coef": 1.0, "bc_decay": 0.5, "lr": 1e-2}
    lines: list[str] = []
    out = train(_tiny_cfg(epochs=0 + 2, **kw), TINY_SPECS, tmp_path / "a", log=lines.append)
    assert not any(line.startswith("imitation epoch") for line in lines)
    params, _, config = load(out)
    assert config["training"]["epochs_done"] == 2 and config["training"]["imitation"] == []
    bc_params, _, _ = load(bc)
    assert any(not np.array_equal(params[k], bc_params[k]) for k in params)
    curve = (out / "curve.csv").read_text().splitlines()
    assert float(curve[1].split(",")[-2]) >= 0.0  # bc_kl column
    train(_tiny_cfg(epochs=1, **kw), TINY_SPECS, tmp_path / "c")
    train(_tiny_cfg(epochs=2, **kw), TINY_SPECS, tmp_path / "c", resume=True)
    assert (tmp_path / "c" / "weights.npz").read_bytes() == (out / "weights.npz").read_bytes()
    wide = NetConfig(embed=8, heads=2, ff=12, hidden=11)
    with pytest.raises(ValueError, match="init_checkpoint"):
        train(_tiny_cfg(net=wide, **kw), TINY_SPECS, tmp_path / "d")


def test_checkpoint_round_trip_and_errors(tmp_path) -> None:  # noqa: ANN001
    params = init_params(NET, 3)
    save(tmp_path / "ck", params, NET, {"eta": 10.0})
    got, net, config = load(tmp_path / "ck")
    assert net == NET and config["training"] == {"eta": 10.0}
    for k in params:
        np.testing.assert_array_equal(got[k], params[k])
    with pytest.raises(CheckpointError, match="neither a folder"):
        load(tmp_path / "nope")
    (tmp_path / "ck" / "weights.npz").unlink()
    with pytest.raises(CheckpointError, match="weights.npz is missing"):
        load(tmp_path / "ck")
    bad = dict(params)
    bad["embed.weight"] = np.zeros((2, 2), dtype=np.float32)
    with pytest.raises(CheckpointError, match="embed.weight has shape"):
        save(tmp_path / "bad", bad, NET)
    assert param_count(NetConfig()) == sum(int(np.prod(v.shape)) for v in
                                           init_params(NetConfig()).values())


def test_checkpoint_plans_deterministically(tmp_path) -> None:  # noqa: ANN001
    save(tmp_path / "ck", _random_params(NET, 21), NET)
    problem = Problem(MAPS / "tiny.json")
    results = []
    for _ in range(2):
        conf = PolicyConfigurator(checkpoint=tmp_path / "ck")
        results.append(run(problem, configurator=conf, seed=5, population=10, budget=200))
    assert np.array_equal(results[0].x, results[1].x)
    assert results[0].history.best_f.tobytes() == results[1].history.best_f.tobytes()
    other = run(problem, configurator=PolicyConfigurator(checkpoint=tmp_path / "ck"), seed=6,
                population=10, budget=200)
    assert not np.array_equal(other.x, results[0].x)
    mode = run(problem, configurator=PolicyConfigurator(checkpoint=tmp_path / "ck", mode=True),
               seed=5, population=10, budget=200)
    assert mode.evaluations == 200


def test_start_modes() -> None:
    problem = Problem(MAPS / "tiny.json")
    assert with_init(problem, "seeded") is problem
    uni = with_init(problem, "uniform")
    assert isinstance(uni, UniformStart) and not hasattr(uni, "initial_population")
    X = problem.lower + 0.5 * (problem.upper - problem.lower)
    assert np.array_equal(uni.evaluate(X[None])[0], problem.evaluate(X[None])[0])
    with pytest.raises(ValueError, match="init: unknown start mode"):
        with_init(problem, "random")


def test_problem_sets_are_disjoint(tmp_path) -> None:  # noqa: ANN001
    train_seeds = {s["seed"] for s in default_training_specs(40)}
    val_seeds = {s["seed"] for s in validation_specs(20)}
    assert not train_seeds & val_seeds and SUITE_SEED not in train_seeds | val_seeds
    assert min(train_seeds) == TRAIN_SEED_BASE and min(val_seeds) == VALIDATION_SEED_BASE
    path = tmp_path / "trainset.json"
    path.write_text(json.dumps({"problems": [{"kind": "map", "path": "m.json"}]}))
    assert read_trainset(path)[0]["path"] == str(tmp_path / "m.json")
    path.write_text(json.dumps({"problems": []}))
    with pytest.raises(ValueError, match="non-empty 'problems'"):
        read_trainset(path)


@pytest.mark.slow  # measured 7.6 s on a loaded machine (default suite <= 5 min)
def test_imitation_lowers_the_loss_on_a_fixed_batch() -> None:
    """Behaviour cloning: demonstrations of `adaptive` on a tiny map, then a few maximum-
    likelihood steps lower the imitation loss (NLL of adaptive's choices + value loss)."""
    torch = pytest.importorskip("torch")
    from planner_core.learning.policy.imitation import collect_demos
    from planner_core.learning.policy.ppo import TorchPolicy, batch_obs, imitation_loss, pretrain

    problem = Problem(MAPS / "tiny.json")
    demos = collect_demos([problem], ["tiny"], configurator="adaptive",
                          init_modes=("uniform", "seeded"), seed=0, population=8, budget=80,
                          gamma=0.99, eta=10.0, delta=1e-8, stride=3)
    assert demos.actions.shape[1:] == (8, 4) and len(demos.obs) == len(demos.returns)
    assert {k.split("/")[1] for k in demos.names} == {"uniform", "seeded"}
    assert 0 < demos.actions[..., 2].min() and demos.actions[..., 3].max() < 1
    torch.manual_seed(0)
    model = TorchPolicy(NET)
    model.load_numpy(init_params(NET, 0))
    batch = (batch_obs(demos.obs), torch.from_numpy(demos.actions),
             torch.from_numpy(demos.returns))
    with torch.no_grad():
        before = float(imitation_loss(model, *batch, vf_coef=0.5)[0])
    rows = pretrain(model, demos, epochs=5, batch=len(demos.obs), lr=1e-2, vf_coef=0.5,
                    max_grad_norm=0.5, seed=0)
    with torch.no_grad():
        after = float(imitation_loss(model, *batch, vf_coef=0.5)[0])
    assert after < before and len(rows) == 5 and rows[-1]["nll"] < rows[0]["nll"]


def test_reward_scaler_makes_problem_scales_alike() -> None:
    """Rewards divided by the running std of the discounted return: the same episode shape at
    100x the scale gives the same scaled rewards, keys are independent, clipped at +-clip."""
    pytest.importorskip("torch")
    from planner_core.learning.policy.imitation import RewardScaler

    rng = np.random.default_rng(0)
    r = rng.exponential(1e-3, 50)
    a, b = RewardScaler(0.99), RewardScaler(0.99)
    a.reset("small")
    a.reset("big")
    b.reset("small")
    small = a.scale("small", r)
    big = a.scale("big", 100.0 * r)
    np.testing.assert_allclose(small, big, rtol=1e-5)  # up to the eps of the std
    np.testing.assert_allclose(b.scale("small", r), small)  # "big" did not touch "small"
    R = np.zeros_like(r)
    acc = 0.0
    for t, x in enumerate(r):
        acc = 0.99 * acc + x
        R[t] = acc
    np.testing.assert_allclose(small, r / (R.std() + 1e-8), rtol=1e-9)
    c = RewardScaler(0.99, clip=2.0)
    c.reset("k")
    assert np.abs(c.scale("k", np.r_[np.zeros(20), 50.0])).max() == 2.0


def test_warm_start_alone_is_a_checkpoint(tmp_path) -> None:  # noqa: ANN001
    """epochs=0: the behaviour-cloning warm start alone, written as epoch 0 (empty curve);
    without a warm start 0 epochs is refused."""
    pytest.importorskip("torch")
    from planner_core.learning.policy.ppo import train

    out = train(_tiny_cfg(epochs=0), TINY_SPECS, tmp_path / "bc")
    _, net, config = load(out)
    assert config["training"]["epochs_done"] == 0 and len(config["training"]["imitation"]) == 2
    assert (out / "curve.csv").read_text().splitlines()[1:] == []
    assert (out / "imitation.csv").read_text().splitlines()[0] == "epoch,nll,value_loss,seconds"
    assert len((out / "imitation.csv").read_text().splitlines()) == 3
    with pytest.raises(ValueError, match="warm start"):
        train(_tiny_cfg(epochs=0, imitate="none"), TINY_SPECS, tmp_path / "none")


class _BrokenModule:
    """A module whose names raise what a broken install raises on import (not ImportError)."""

    def __getattr__(self, name: str) -> object:
        raise RuntimeError("a broken tensorboard install")


def test_the_tensorboard_writer_is_optional_but_a_broken_install_is_not_hidden(
    monkeypatch: pytest.MonkeyPatch, tmp_path
) -> None:
    pytest.importorskip("torch")
    from planner_core.learning.policy.ppo import _scalar_writer

    # neither installed (a None entry in sys.modules makes the import raise ImportError)
    monkeypatch.setitem(sys.modules, "torch.utils.tensorboard", None)
    monkeypatch.setitem(sys.modules, "tensorboardX", None)
    assert _scalar_writer(tmp_path) is None
    monkeypatch.setitem(sys.modules, "torch.utils.tensorboard", _BrokenModule())
    with pytest.raises(RuntimeError, match="broken tensorboard"):
        _scalar_writer(tmp_path)
